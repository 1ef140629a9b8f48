#pragma once
// Finds and loads technique plugins (shared libraries named penumbra-<name>.so) from a
// search path: $PENUMBRA_PLUGIN_PATH (colon-separated) first, then the engine's own
// plugin folder: the build tree's for the library the build tree made, the install
// tree's (<libdir>/penumbra/plugins) for an installed one, never both. Only the plugins
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
    FileMissing,         // no penumbra-<name>.so on the search path: the folders searched
    NotALibrary,         // the file is not an ELF shared library (garbage, a script, an executable)
    DependencyMissing,   // dlopen failed (a library or symbol it needs is missing): dlerror text
    EntryMissing,        // no penumbra_plugin_entry symbol (not a Penumbra plugin)
    AbiMismatch,         // built for another ABI version: both numbers
    InvalidInfo,         // the entry's PenumbraPluginInfo is malformed (null fields, bad specs)
    DuplicateName,       // two files declare one plugin name (the first on the path wins)
    NameMismatch,        // penumbra-<a>.so declares name <b>
    RegistrationFailed,  // an exception while creating the technique or registering passes
};
// "file-missing", "dependency-missing", ...: for messages and `penumbra plugins --json`.
const char* pluginErrorKindName(PluginErrorKind kind);

class PluginError : public Error {
public:
    PluginError(PluginErrorKind kind, const std::string& message, std::filesystem::path file = {})
        : Error(message), kind_(kind), file_(std::move(file))
    {
    }
    PluginErrorKind kind() const { return kind_; }
    // The plugin file the error is about; empty when there is none (FileMissing).
    const std::filesystem::path& file() const { return file_; }

private:
    PluginErrorKind kind_;
    std::filesystem::path file_;
};

// A loaded plugin: its library stays loaded while the registry lives.
struct LoadedPlugin {
    std::filesystem::path file;
    const PenumbraPluginInfo* info = nullptr;
    std::filesystem::path shaderDir;  // resolved (see PenumbraPluginInfo::shaderDir)

    std::string_view name() const { return info->name; }
    ParamValues defaultParams() const { return ParamValues(info->name, info->params, info->paramCount); }
};

// The default search path (see the file comment), existing folders only, each once.
std::vector<std::filesystem::path> defaultPluginSearchPath();

// Checks what a plugin's entry returned, after its ABI version matched: name, version,
// summary and factory present, the name a plugin name ([a-z0-9_-]+), every parameter
// spec sane (unique snake_case names, a known type, unit and doc present, Int/Float
// ranges finite with min <= default <= max, Int values integral and within int, Bool
// default 0 or 1, Enum choices present and unique with the default among them). Throws
// PluginError InvalidInfo naming `file` and the field.
void checkPluginInfo(const PenumbraPluginInfo& info, const std::filesystem::path& file);

class PluginRegistry {
public:
    explicit PluginRegistry(std::vector<std::filesystem::path> searchPath = defaultPluginSearchPath());
    // Unloads the libraries: every technique a plugin created must be destroyed first.
    ~PluginRegistry();
    PluginRegistry(const PluginRegistry&) = delete;
    PluginRegistry& operator=(const PluginRegistry&) = delete;

    const std::vector<std::filesystem::path>& searchPath() const { return searchPath_; }

    // Loads penumbra-<name>.so (the first on the search path), or returns the plugin
    // loaded before. Throws PluginError; the registry stays usable after a failure.
    const LoadedPlugin& load(std::string_view name);

    // Every plugin file (penumbra-*.so) on the search path, loaded, in search-path order
    // (by file name within a folder); a file that fails is reported in `errors` and
    // skipped (for `penumbra plugins`). A second file declaring a name already loaded is a
    // DuplicateName error: the first on the path wins, as for load().
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
    // Every library dlopen'd, refused ones too: nothing is unloaded while the registry
    // lives, so no pointer into a library (info, specs, vtables) can dangle.
    std::vector<void*> handles_;
};

} // namespace penumbra::plugin
