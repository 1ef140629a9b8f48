#include "penumbra/plugin/LibraryFile.h"

#include "penumbra/plugin/PluginRegistry.h"

#include "core/Text.h"

#include <fmt/format.h>

#include <link.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <vector>

namespace fs = std::filesystem;

namespace penumbra::plugin {

void checkSharedLibraryFile(const fs::path& file, const std::string& who)
{
    auto fail = [&](const std::string& what) {
        throw PluginError(PluginErrorKind::NotALibrary,
                          fmt::format("{}: not a shared library: {}; rebuild the plugin (a CMake MODULE library) or "
                                      "remove the file from the plugin search path",
                                      who, what),
                          file);
    };
    std::error_code ec;
    const fs::file_status status = fs::status(file, ec);  // follows links
    if (status.type() != fs::file_type::regular) fail(fmt::format("it is {}", core::fileTypeName(status.type())));
    const uintmax_t size = fs::file_size(file, ec);
    if (ec) fail(fmt::format("cannot read its size ({})", ec.message()));
    std::ifstream in(file, std::ios::binary);
    if (!in) fail(fmt::format("cannot read the file ({})", std::strerror(errno)));
    ElfW(Ehdr) header{};
    in.read(reinterpret_cast<char*>(&header), sizeof header);
    const auto got = size_t(in.gcount());
    if (got < SELFMAG || std::memcmp(header.e_ident, ELFMAG, SELFMAG) != 0) fail("it is not an ELF file");
    if (got < sizeof header) fail(fmt::format("the ELF header is truncated ({} bytes)", got));
    constexpr unsigned char nativeClass = sizeof(void*) == 8 ? ELFCLASS64 : ELFCLASS32;
    if (header.e_ident[EI_CLASS] != nativeClass) {
        fail(fmt::format("it is a {}-bit ELF file, this engine is {}-bit", header.e_ident[EI_CLASS] == ELFCLASS64 ? 64 : 32,
                         sizeof(void*) * 8));
    }
    if (header.e_type != ET_DYN) fail("it is an ELF executable or object file, not a shared object");

    // The headers and segments must lie inside the file. Sizes are 64-bit here and the
    // sums are checked piecewise, so no overflow hides one.
    const auto within = [size](uint64_t offset, uint64_t bytes) { return offset <= size && bytes <= size - offset; };
    const std::string damaged = fmt::format("it is damaged or truncated ({} bytes)", size);
    if (header.e_phentsize != sizeof(ElfW(Phdr)) || header.e_phnum == 0 ||
        !within(header.e_phoff, uint64_t(header.e_phnum) * sizeof(ElfW(Phdr)))) {
        fail(damaged + ": its program header table lies beyond the file's end or is malformed");
    }
    if (header.e_shoff != 0 && (header.e_shentsize != sizeof(ElfW(Shdr)) ||
                                !within(header.e_shoff, uint64_t(header.e_shnum) * sizeof(ElfW(Shdr))))) {
        fail(damaged + ": its section header table lies beyond the file's end or is malformed");
    }
    std::vector<ElfW(Phdr)> segments(header.e_phnum);
    in.seekg(std::streamoff(header.e_phoff));
    in.read(reinterpret_cast<char*>(segments.data()), std::streamsize(segments.size() * sizeof(ElfW(Phdr))));
    if (size_t(in.gcount()) != segments.size() * sizeof(ElfW(Phdr))) fail(damaged + ": its program headers cannot be read");
    bool loads = false, dynamic = false;
    for (size_t i = 0; i < segments.size(); ++i) {
        const ElfW(Phdr)& p = segments[i];
        if (p.p_type != PT_LOAD && p.p_type != PT_DYNAMIC) continue;
        if (!within(p.p_offset, p.p_filesz)) {
            fail(fmt::format("{}: segment {} (bytes {} to {}) lies beyond the file's end", damaged, i, uint64_t(p.p_offset),
                             uint64_t(p.p_offset) + uint64_t(p.p_filesz)));
        }
        if (p.p_type == PT_LOAD) {
            loads = true;
            if (p.p_filesz > p.p_memsz) fail(fmt::format("{}: segment {} holds more bytes in the file than in memory", damaged, i));
            if (p.p_align > 1 && ((p.p_align & (p.p_align - 1)) != 0 || p.p_offset % p.p_align != p.p_vaddr % p.p_align)) {
                fail(fmt::format("{}: segment {} is misaligned", damaged, i));
            }
        } else {
            dynamic = true;
        }
    }
    if (!loads || !dynamic) fail(damaged + ": it has no loadable or no dynamic segment");
}

} // namespace penumbra::plugin
