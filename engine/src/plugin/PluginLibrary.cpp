#include "plugin/PluginLibrary.h"

#include "penumbra/plugin/LibraryFile.h"
#include "penumbra/plugin/PluginRegistry.h"

#include "gpu/SanitizerSupport.h"

#include <fmt/format.h>

#include <dlfcn.h>

namespace fs = std::filesystem;

namespace penumbra::plugin {

const PenumbraPluginInfo& openPluginLibrary(const fs::path& file, const std::string& who, std::vector<void*>& handles)
{
    checkSharedLibraryFile(file, who);
    dlerror();
    void* handle = dlopen(file.c_str(), RTLD_NOW | RTLD_LOCAL | gpu::noUnloadDlopenFlag());
    if (!handle) {
        const char* why = dlerror();
        throw PluginError(PluginErrorKind::DependencyMissing,
                          fmt::format("{}: cannot be loaded: {}. A library it links is missing or incompatible, or it "
                                      "needs a symbol this engine lacks: check `ldd -r {}`, install the library or add "
                                      "its folder to LD_LIBRARY_PATH, or rebuild the plugin against this engine",
                                      who, why ? why : "unknown dlopen error", file.string()),
                          file);
    }
    handles.push_back(handle);

    dlerror();
    void* symbol = dlsym(handle, PENUMBRA_PLUGIN_ENTRY_SYMBOL);
    if (!symbol) {
        throw PluginError(PluginErrorKind::EntryMissing,
                          fmt::format("{}: not a Penumbra plugin: no {} symbol; a plugin exports it with "
                                      "PENUMBRA_PLUGIN_EXPORT (penumbra/plugin/Plugin.h)",
                                      who, PENUMBRA_PLUGIN_ENTRY_SYMBOL),
                          file);
    }
    const auto entry = reinterpret_cast<PenumbraPluginEntryFn>(symbol);
    const PenumbraPluginInfo* info = nullptr;
    auto invalid = [&](const std::string& what) {
        return PluginError(PluginErrorKind::InvalidInfo, fmt::format("{}: {}: fix the plugin", who, what), file);
    };
    try {
        info = entry();
    } catch (const std::exception& e) {
        throw invalid(fmt::format("{} threw: {}", PENUMBRA_PLUGIN_ENTRY_SYMBOL, e.what()));
    } catch (...) {
        throw invalid(fmt::format("{} threw an exception", PENUMBRA_PLUGIN_ENTRY_SYMBOL));
    }
    if (!info) throw invalid(fmt::format("{} returned null", PENUMBRA_PLUGIN_ENTRY_SYMBOL));
    // The one member read before the check: every other member's layout may differ.
    if (info->abiVersion != PENUMBRA_PLUGIN_ABI_VERSION) {
        throw PluginError(PluginErrorKind::AbiMismatch,
                          fmt::format("{}: built for plugin ABI {}, this engine has ABI {}: rebuild the plugin against "
                                      "this engine",
                                      who, info->abiVersion, PENUMBRA_PLUGIN_ABI_VERSION),
                          file);
    }
    checkPluginInfo(*info, file);
    return *info;
}

namespace {

// Whether `dir` holds GLSL files: penumbra_add_plugin installs a plugin's shaders there. A
// build tree has a CMake folder of the same name beside the module, without any.
bool holdsShaders(const fs::path& dir)
{
    std::error_code ec;
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
        const std::string ext = it->path().extension().string();
        for (const char* glsl : {".comp", ".vert", ".frag", ".geom", ".tesc", ".tese", ".glsl"})
            if (ext == glsl) return true;
    }
    return false;
}

} // namespace

fs::path pluginShaderDir(const PenumbraPluginInfo& info, const fs::path& file)
{
    // An installed plugin reads its installed shaders, even where the tree it was built in
    // still exists; a plugin in its build folder reads its source folder, so that shaders
    // can be edited without rebuilding.
    const fs::path installed = file.parent_path() / info.name;
    if (holdsShaders(installed)) return installed;
    std::error_code ec;
    if (info.shaderDir && fs::is_directory(info.shaderDir, ec)) return info.shaderDir;
    return installed;
}

} // namespace penumbra::plugin
