#pragma once
// The check a plugin file passes before dlopen sees it (plugin/PluginRegistry.h calls it
// for `plugins`, `plugins --strict` and `render` alike; tests/fuzz fuzzes it).
#include <filesystem>
#include <string>

namespace penumbra::plugin {

// Throws PluginError(NotALibrary) naming `who` (a plugin name or file) and what is wrong
// when dlopen would refuse `file` for its shape, or crash on it, instead of the loader's
// "invalid ELF header" or a SIGBUS: not a regular file (a FIFO would block the read
// forever; a directory or a dangling link), garbage, a text file, a 32-bit build, an
// executable, and a damaged library whose program headers or segments lie beyond the
// file's end (a truncated copy: the loader maps the segments and dies touching pages past
// the end) or do not hang together (bit flips in the headers). Reads only the headers.
void checkSharedLibraryFile(const std::filesystem::path& file, const std::string& who);

} // namespace penumbra::plugin
