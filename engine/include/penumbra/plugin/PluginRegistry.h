#pragma once
// Finds and loads technique plugins (shared libraries named penumbra-<name>.so) from a
// search path: $PENUMBRA_PLUGIN_PATH (colon-separated) first, then the build tree's
// plugin folder, then the install tree's (<libdir>/penumbra/plugins). Only the plugins
// a config names are loaded. Each failure has its own error kind and message.
#include "penumbra/core/Error.h"
#include "penumbra/plugin/Params.h"
#include "penumbra/plugin/Plugin.h"
#include "penumbra/plugin/Technique.h"

#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra::plugin {

enum class PluginErrorKind {
    FileMissing,         // no penumbra-<name>.so on the search path
    DependencyMissing,   // dlopen failed (a library it needs is missing): dlerror text
    EntryMissing,        // no penumbra_plugin_entry symbol (not a Penumbra plugin)
    AbiMismatch,         // built for another ABI version: both numbers
    DuplicateName,       // two files declare one plugin name
    NameMismatch,        // penumbra-<a>.so declares name <b>
    RegistrationFailed,  // an exception while creating the technique or registering passes
};
const char* pluginErrorKindName(PluginErrorKind kind);

class PluginError : public Error {
public:
    PluginError(PluginErrorKind kind, const std::string& message) : Error(message), kind_(kind) {}
    PluginErrorKind kind() const { return kind_; }

private:
    PluginErrorKind kind_;
};

// A loaded plugin: its library stays loaded while the registry lives.
struct LoadedPlugin {
    std::filesystem::path file;
    const PenumbraPluginInfo* info = nullptr;
    std::filesystem::path shaderDir;  // resolved (see PenumbraPluginInfo::shaderDir)

    std::string_view name() const { return info->name; }
    ParamValues defaultParams() const { return ParamValues(info->name, info->params, info->paramCount); }
};

// The default search path (see the file comment), existing folders only.
std::vector<std::filesystem::path> defaultPluginSearchPath();

class PluginRegistry {
public:
    explicit PluginRegistry(std::vector<std::filesystem::path> searchPath = defaultPluginSearchPath());
    // Unloads the libraries: every technique a plugin created must be destroyed first.
    ~PluginRegistry();
    PluginRegistry(const PluginRegistry&) = delete;
    PluginRegistry& operator=(const PluginRegistry&) = delete;

    const std::vector<std::filesystem::path>& searchPath() const { return searchPath_; }

    // Loads penumbra-<name>.so (the first on the search path), or returns the plugin
    // loaded before. Throws PluginError.
    const LoadedPlugin& load(std::string_view name);

    // Every plugin file on the search path, loaded, in search-path order; a file that
    // fails is reported in `errors` and skipped (for `penumbra plugins`).
    struct Discovery {
        std::vector<const LoadedPlugin*> plugins;
        std::vector<PluginError> errors;
    };
    Discovery discoverAll();

    // Creates a technique through the plugin's factory; exceptions (and a null result)
    // become PluginError RegistrationFailed naming the plugin and `context` ("light 0").
    std::unique_ptr<Technique> create(const LoadedPlugin& plugin, const TechniqueSetup& setup,
                                      const std::string& context) const;

private:
    const LoadedPlugin& loadFile(const std::filesystem::path& file, std::string_view expectedName);

    std::vector<std::filesystem::path> searchPath_;
    std::vector<std::unique_ptr<LoadedPlugin>> loaded_;
    std::vector<void*> handles_;
};

} // namespace penumbra::plugin
