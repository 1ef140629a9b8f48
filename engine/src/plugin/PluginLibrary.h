#pragma once
// Opening a plugin file in the calling process: the pre-load check (plugin/LibraryFile.h),
// dlopen, the entry point, the ABI version and checkPluginInfo. The plugin scanner
// (engine/scanner/) does it in a process of its own; the registry does it only after the
// scanner read the same file without harm (plugin/PluginRegistry.h).
#include "penumbra/plugin/Plugin.h"

#include <filesystem>
#include <string>
#include <vector>

namespace penumbra::plugin {

// Returns the entry's info, checked. Throws PluginError (NotALibrary, DependencyMissing,
// EntryMissing, AbiMismatch, InvalidInfo) naming `who` ("plugin 'hard' (<file>)"). Every
// handle dlopen gave is appended to `handles`, a refused plugin's too: the caller keeps
// them open while anything may point into the library.
const PenumbraPluginInfo& openPluginLibrary(const std::filesystem::path& file, const std::string& who,
                                            std::vector<void*>& handles);

// Where a plugin's GLSL lives: its declared folder when that exists (a build tree), else
// <file's folder>/<name>/ (an install).
std::filesystem::path pluginShaderDir(const PenumbraPluginInfo& info, const std::filesystem::path& file);

} // namespace penumbra::plugin
