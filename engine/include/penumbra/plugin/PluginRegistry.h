#pragma once
// Finds, scans and loads technique plugins (shared libraries named penumbra-<name>.so)
// from a search path: $PENUMBRA_PLUGIN_PATH (colon-separated) first, then the engine's
// own plugin folder: the build tree's for the library the build tree made, the install
// tree's (<libdir>/penumbra/plugins) for an installed one, never both.
//
// A plugin is first scanned: the plugin scanner (engine/scanner/, a program of its own)
// loads it in a separate process and reports what it declares (PluginMetadata), so that a
// damaged or hostile file can crash or hang only the scanner. Listing plugins and checking
// configs use the scans alone; a plugin's code runs in the engine's process only when a
// render loads it, and only after its scan succeeded. Scans are cached by file identity
// (plugin/ScanCache.h in the engine; docs/plugins.md). Only the plugins a config names are
// loaded. Each failure has its own error kind and message.
#include "penumbra/core/Error.h"
#include "penumbra/plugin/Params.h"
#include "penumbra/plugin/Plugin.h"
#include "penumbra/plugin/PluginMetadata.h"
#include "penumbra/plugin/Technique.h"

#include <chrono>
#include <filesystem>
#include <memory>
#include <optional>
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
    ScanFailed,          // the plugin scanner died (a signal), exited, hung or could not start while loading it
};
// "file-missing", "dependency-missing", ...: for messages and `penumbra plugins --json`.
const char* pluginErrorKindName(PluginErrorKind kind);
// The kind a name stands for (the plugin scanner reports kinds by name).
std::optional<PluginErrorKind> pluginErrorKindNamed(std::string_view name);

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

// The plugin scanner executable: $PENUMBRA_PLUGIN_SCANNER when set, else the build tree's
// for the library the build tree made, else <libexecdir>/penumbra/penumbra-plugin-scanner
// of the install this library belongs to.
std::filesystem::path defaultPluginScanner();
// $XDG_CACHE_HOME/penumbra/plugin-scan-<ABI>.json, or ~/.cache/penumbra/... when
// XDG_CACHE_HOME is unset or not absolute; empty (no cache) when neither is known.
std::filesystem::path defaultScanCacheFile();

// How a registry scans plugin files.
struct ScanSettings {
    std::filesystem::path scanner = defaultPluginScanner();
    // A scan that takes longer is stopped (SIGKILL) and reported; loading a plugin takes
    // milliseconds, this leaves room for sanitizer builds and loaded machines.
    std::chrono::milliseconds timeout{30000};
    std::filesystem::path cacheFile = defaultScanCacheFile();  // empty: scan every time
};

// Checks what a plugin's entry returned, after its ABI version matched: name, version,
// summary and factory present, the name a plugin name ([a-z0-9_-]+), every parameter
// spec sane (unique snake_case names, a known type, unit and doc present, Int/Float
// ranges finite with min <= default <= max, Int values integral and within int, Bool
// default 0 or 1, Enum choices present and unique with the default among them). Throws
// PluginError InvalidInfo naming `file` and the field.
void checkPluginInfo(const PenumbraPluginInfo& info, const std::filesystem::path& file);

class ScanCache;

class PluginRegistry {
public:
    explicit PluginRegistry(std::vector<std::filesystem::path> searchPath = defaultPluginSearchPath(),
                            ScanSettings scanSettings = {});
    // Unloads the libraries: every technique a plugin created must be destroyed first.
    ~PluginRegistry();
    PluginRegistry(const PluginRegistry&) = delete;
    PluginRegistry& operator=(const PluginRegistry&) = delete;

    const std::vector<std::filesystem::path>& searchPath() const { return searchPath_; }

    // What penumbra-<name>.so (the first on the search path) declares, read by the plugin
    // scanner in a process of its own (or the cache); nothing of the plugin runs here.
    // Returns the scan made before for the same file. Throws PluginError; the registry
    // stays usable after a failure.
    const PluginMetadata& scan(std::string_view name);

    // Every plugin file (penumbra-*.so) on the search path, scanned, in search-path order
    // (by file name within a folder); a file that fails is reported in `errors` (for
    // `penumbra plugins`). A second file declaring a name found before is a DuplicateName
    // error and is not scanned: the first on the path wins, as for load().
    struct Scan {
        std::vector<const PluginMetadata*> plugins;
        std::vector<PluginError> errors;
    };
    Scan scanAll();

    // Scans penumbra-<name>.so, then (only when the scan succeeded) loads it into this
    // process, or returns the plugin loaded before. Throws PluginError.
    const LoadedPlugin& load(std::string_view name);

    // Creates a technique through the plugin's factory; exceptions (and a null result)
    // become PluginError RegistrationFailed naming the plugin and `context` ("light 0").
    std::unique_ptr<Technique> create(const LoadedPlugin& plugin, const TechniqueSetup& setup,
                                      const std::string& context) const;

private:
    struct ScanRecord;
    std::filesystem::path locate(std::string_view name) const;
    const PluginMetadata& scanFile(const std::filesystem::path& file, std::string_view expectedName);
    void checkNotShadowed(const std::filesystem::path& file, std::string_view name,
                          const std::vector<const PluginMetadata*>& found) const;
    ScanCache& cache();

    std::vector<std::filesystem::path> searchPath_;
    ScanSettings scanSettings_;
    std::unique_ptr<ScanCache> cache_;  // read at the first scan
    std::vector<std::unique_ptr<ScanRecord>> scans_;
    std::vector<std::unique_ptr<LoadedPlugin>> loaded_;
    // Every library dlopen'd, refused ones too: nothing is unloaded while the registry
    // lives, so no pointer into a library (info, specs, vtables) can dangle.
    std::vector<void*> handles_;
};

} // namespace penumbra::plugin
