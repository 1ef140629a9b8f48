#include "penumbra/plugin/PluginRegistry.h"

#include "penumbra/io/CacheFolder.h"
#include "penumbra/plugin/LibraryFile.h"

#include "core/BuildTree.h"
#include "core/Text.h"
#include "plugin/PluginLibrary.h"
#include "plugin/PluginScanner.h"
#include "plugin/ScanCache.h"

#include <fmt/format.h>

#include <dlfcn.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <set>
#include <vector>

namespace fs = std::filesystem;

namespace penumbra::plugin {
namespace {

constexpr const char* kPathVariable = "PENUMBRA_PLUGIN_PATH";
constexpr const char* kScannerVariable = "PENUMBRA_PLUGIN_SCANNER";
constexpr std::string_view kFilePrefix = "penumbra-";
constexpr std::string_view kFileSuffix = ".so";

std::string pluginFileName(std::string_view name) { return fmt::format("{}{}{}", kFilePrefix, name, kFileSuffix); }

// The names configs use: lower case, digits, '_' and '-' (config/Config.cpp checks the
// same for "technique").
bool isPluginName(std::string_view name)
{
    return !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
        return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
    });
}

bool isParamName(std::string_view name)
{
    return !name.empty() && name[0] >= 'a' && name[0] <= 'z' && std::all_of(name.begin(), name.end(), [](char c) {
        return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_';
    });
}

// "hard" for ".../penumbra-hard.so"; empty when the file name has another shape.
std::string nameFromFile(const fs::path& file)
{
    const std::string base = file.filename().string();
    if (base.size() <= kFilePrefix.size() + kFileSuffix.size() || !base.starts_with(kFilePrefix) || !base.ends_with(kFileSuffix)) {
        return {};
    }
    return base.substr(kFilePrefix.size(), base.size() - kFilePrefix.size() - kFileSuffix.size());
}

// The plugin files of one folder, by file name; none when the folder cannot be read.
// Everything named like a plugin counts, a directory or a FIFO too: loading it reports
// what it is (checkSharedLibraryFile), the same way for `plugins` as for `render`.
std::vector<fs::path> pluginFiles(const fs::path& dir)
{
    std::vector<fs::path> files;
    std::error_code ec;
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
        if (!nameFromFile(it->path()).empty()) files.push_back(it->path());
    }
    std::sort(files.begin(), files.end());
    return files;
}

fs::path canonicalOrSelf(const fs::path& p)
{
    std::error_code ec;
    fs::path canonical = fs::weakly_canonical(p, ec);
    return ec ? p : canonical;
}

// Each folder once (by canonical path), in order.
std::vector<fs::path> uniqueFolders(std::vector<fs::path> folders)
{
    std::vector<fs::path> out;
    std::set<fs::path> seen;
    for (fs::path& f : folders)
        if (seen.insert(canonicalOrSelf(f)).second) out.push_back(std::move(f));
    return out;
}

// The folder of the engine library that holds this code; empty if the loader cannot say.
fs::path engineLibraryDir()
{
    static const int anchor = 0;
    Dl_info info{};
    if (dladdr(&anchor, &info) == 0 || !info.dli_fname) return {};
    return fs::path(info.dli_fname).parent_path();
}

bool isBuildTreeLibrary(const fs::path& library)
{
    std::error_code ec;
    return fs::equivalent(library, core::buildTreeLibraryDir(), ec);
}

// The engine's own plugins: the build tree's plugins/ for the library the build tree made,
// <libdir>/penumbra/plugins beside any other copy of it (an install, wherever it was
// installed to). Never both: an installed engine must not load the plugins of the tree
// it was built in, which may still exist on the build machine and declare the same names.
fs::path enginePluginDir()
{
    const fs::path library = engineLibraryDir();
    if (library.empty()) return {};
    if (isBuildTreeLibrary(library)) return core::buildTreePluginDir();
    return library / "penumbra" / "plugins";
}

std::string searchPathHint()
{
    const char* env = std::getenv(kPathVariable);
    return env ? fmt::format("{}={}", kPathVariable, env) : fmt::format("{} is not set", kPathVariable);
}

// What a file that is not a regular file is, for a message.
void checkParamSpec(const penumbra::plugin::ParamSpec& spec, const std::string& at, const std::function<void(std::string)>& fail)
{
    if (!spec.unit) fail(at + ": unit is null (use \"\" when unitless)");
    if (!spec.doc) fail(at + ": doc is null");
    if (spec.odd && spec.type != ParamType::Int) fail(at + ": only an int can be odd-only (odd)");
    auto finite = [&](double v, const char* what) {
        if (!std::isfinite(v)) fail(fmt::format("{}: {} is not finite", at, what));
    };
    switch (spec.type) {
    case ParamType::Bool:
        if (spec.defaultValue != 0.0 && spec.defaultValue != 1.0) {
            fail(fmt::format("{}: a bool's default must be 0 or 1, got {}", at, spec.defaultValue));
        }
        return;
    case ParamType::Int:
    case ParamType::Float:
        finite(spec.defaultValue, "the default");
        finite(spec.minValue, "min");
        finite(spec.maxValue, "max");
        if (!(spec.minValue <= spec.defaultValue && spec.defaultValue <= spec.maxValue)) {
            fail(fmt::format("{}: needs min <= default <= max, got min {}, default {}, max {}", at, spec.minValue,
                             spec.defaultValue, spec.maxValue));
        }
        if (spec.type == ParamType::Int) {
            for (double v : {spec.minValue, spec.defaultValue, spec.maxValue}) {
                if (v != std::floor(v) || v < double(INT_MIN) || v > double(INT_MAX)) {
                    fail(fmt::format("{}: an int's min, default and max must be integers within int, got {}", at, v));
                }
                if (spec.odd && std::fmod(v, 2.0) == 0.0)
                    fail(fmt::format("{}: an odd-only int's min, default and max must be odd, got {}", at, v));
            }
        }
        return;
    case ParamType::Enum: {
        if (!spec.choices || spec.choiceCount == 0) fail(at + ": an enum needs choices (choices/choiceCount)");
        std::set<std::string_view> seen;
        for (uint32_t c = 0; c < spec.choiceCount; ++c) {
            if (!spec.choices[c] || !spec.choices[c][0]) fail(fmt::format("{}: choice {} is null or empty", at, c));
            if (!seen.insert(spec.choices[c]).second) fail(fmt::format("{}: choice '{}' is listed twice", at, spec.choices[c]));
        }
        if (spec.defaultValue != std::floor(spec.defaultValue) || spec.defaultValue < 0.0 ||
            spec.defaultValue >= double(spec.choiceCount)) {
            fail(fmt::format("{}: an enum's default is a choice index in [0, {}), got {}", at, spec.choiceCount,
                             spec.defaultValue));
        }
        return;
    }
    }
    fail(fmt::format("{}: unknown type {}", at, uint32_t(spec.type)));
}

} // namespace

const char* pluginErrorKindName(PluginErrorKind kind)
{
    switch (kind) {
    case PluginErrorKind::FileMissing: return "file-missing";
    case PluginErrorKind::NotALibrary: return "not-a-library";
    case PluginErrorKind::DependencyMissing: return "dependency-missing";
    case PluginErrorKind::EntryMissing: return "entry-missing";
    case PluginErrorKind::AbiMismatch: return "abi-mismatch";
    case PluginErrorKind::InvalidInfo: return "invalid-info";
    case PluginErrorKind::DuplicateName: return "duplicate-name";
    case PluginErrorKind::NameMismatch: return "name-mismatch";
    case PluginErrorKind::RegistrationFailed: return "registration-failed";
    case PluginErrorKind::ScanFailed: return "scan-failed";
    }
    return "unknown";
}

std::optional<PluginErrorKind> pluginErrorKindNamed(std::string_view name)
{
    for (int k = 0; k <= int(PluginErrorKind::ScanFailed); ++k)
        if (name == pluginErrorKindName(PluginErrorKind(k))) return PluginErrorKind(k);
    return std::nullopt;
}

std::vector<fs::path> defaultPluginSearchPath()
{
    std::vector<fs::path> candidates;
    if (const char* env = std::getenv(kPathVariable)) {
        std::string_view rest = env;
        while (!rest.empty()) {
            const size_t colon = rest.find(':');
            const std::string_view entry = rest.substr(0, colon);
            if (!entry.empty()) candidates.emplace_back(entry);
            rest = colon == std::string_view::npos ? std::string_view{} : rest.substr(colon + 1);
        }
    }
    if (fs::path own = enginePluginDir(); !own.empty()) candidates.push_back(std::move(own));

    std::vector<fs::path> existing;
    for (fs::path& dir : candidates) {
        std::error_code ec;
        if (fs::is_directory(dir, ec)) existing.push_back(std::move(dir));
    }
    return uniqueFolders(std::move(existing));
}

fs::path defaultPluginScanner()
{
    if (const char* env = std::getenv(kScannerVariable); env && *env) return env;
    // As for the plugin folder: the build tree's scanner for the build tree's library only.
    const fs::path library = engineLibraryDir();
    if (!library.empty() && isBuildTreeLibrary(library)) return core::buildTreeScanner();
    return (library.empty() ? fs::path(core::buildTreeLibraryDir()) : library) / core::scannerFromLibrary();
}

fs::path defaultScanCacheFile()
{
    const fs::path folder = io::userCacheFolder();
    if (folder.empty()) return {};
    return folder / fmt::format("plugin-scan-{}.json", PENUMBRA_PLUGIN_ABI_VERSION);
}

void checkPluginInfo(const PenumbraPluginInfo& info, const fs::path& file)
{
    const std::string who = info.name ? fmt::format("plugin '{}' ({})", info.name, file.string()) : file.string();
    const std::function<void(std::string)> fail = [&](const std::string& what) {
        throw PluginError(PluginErrorKind::InvalidInfo,
                          fmt::format("{}: malformed plugin info: {}; fix what the plugin's penumbra_plugin_entry returns "
                                      "(penumbra/plugin/Plugin.h)",
                                      who, what),
                          file);
    };
    if (!info.name) fail("name is null");
    if (!isPluginName(info.name)) fail(fmt::format("name '{}' is not a plugin name ([a-z0-9_-]+)", info.name));
    if (!info.version) fail("version is null");
    if (!info.summary) fail("summary is null");
    if (!info.create) fail("create (the technique factory) is null");
    if (info.paramCount > 0 && !info.params) fail(fmt::format("params is null but paramCount is {}", info.paramCount));

    std::set<std::string_view> names;
    for (uint32_t i = 0; i < info.paramCount; ++i) {
        const ParamSpec& spec = info.params[i];
        if (!spec.name) fail(fmt::format("params[{}]: name is null", i));
        const std::string at = fmt::format("params[{}] '{}'", i, spec.name);
        if (!isParamName(spec.name)) fail(at + ": not a snake_case name ([a-z][a-z0-9_]*)");
        // The config's "shadow" object uses these keys itself (config/Config.h).
        if (std::string_view(spec.name) == "technique" || std::string_view(spec.name) == "required") {
            fail(at + ": the name is reserved by the config's \"shadow\" object");
        }
        if (!names.insert(spec.name).second) fail(at + ": the name is declared twice");
        checkParamSpec(spec, at, fail);
    }
}

// One file's scan: what it declares, or why it cannot be used.
struct PluginRegistry::ScanRecord {
    fs::path canonical;
    std::optional<PluginMetadata> metadata;
    std::optional<PluginError> error;
};

PluginRegistry::PluginRegistry(std::vector<fs::path> searchPath, ScanSettings scanSettings)
    : searchPath_(uniqueFolders(std::move(searchPath))), scanSettings_(std::move(scanSettings))
{
}

PluginRegistry::~PluginRegistry()
{
    loaded_.clear();
    for (auto it = handles_.rbegin(); it != handles_.rend(); ++it) dlclose(*it);
}

ScanCache& PluginRegistry::cache()
{
    if (!cache_) cache_ = std::make_unique<ScanCache>(scanSettings_.cacheFile);
    return *cache_;
}

fs::path PluginRegistry::locate(std::string_view name) const
{
    if (!isPluginName(name)) {
        throw PluginError(PluginErrorKind::FileMissing,
                          fmt::format("'{}' is not a plugin name: plugin names use a-z, 0-9, '_' and '-'", name));
    }
    for (const fs::path& dir : searchPath_) {
        const fs::path file = dir / pluginFileName(name);
        std::error_code ec;
        // A dangling link counts as there: scanning it says what it is.
        if (fs::exists(fs::symlink_status(file, ec))) return file;
    }

    std::vector<std::string> folders, available;
    for (const fs::path& dir : searchPath_) {
        folders.push_back(dir.string());
        for (const fs::path& file : pluginFiles(dir)) available.push_back(nameFromFile(file));
    }
    std::string found = available.empty() ? "no plugin files there"
                                          : fmt::format("plugins there: {}", fmt::join(available, ", "));
    if (const std::string best = core::closestMatch(name, available); !best.empty()) {
        found += fmt::format("; did you mean '{}'?", best);
    }
    throw PluginError(PluginErrorKind::FileMissing,
                      fmt::format("plugin '{}': no file {} on the plugin search path (searched: {}; {}). Build the "
                                  "plugin, or add the folder that holds it to {} (colon-separated; {})",
                                  name, pluginFileName(name), folders.empty() ? "no folder exists" : fmt::format("{}", fmt::join(folders, ", ")),
                                  found, kPathVariable, searchPathHint()));
}

const PluginMetadata& PluginRegistry::scanFile(const fs::path& file, std::string_view expectedName)
{
    const fs::path canonical = canonicalOrSelf(file);
    for (const auto& record : scans_) {
        if (record->canonical != canonical) continue;
        if (record->error) throw *record->error;
        return *record->metadata;
    }
    auto& record = *scans_.emplace_back(std::make_unique<ScanRecord>(ScanRecord{canonical, std::nullopt, std::nullopt}));
    const std::string who = fmt::format("plugin '{}' ({})", expectedName, file.string());
    try {
        // Reads only: a file the loader would refuse or crash on is named without a scan.
        checkSharedLibraryFile(file, who);
        const std::optional<FileIdentity> identity = identityOf(file);
        std::optional<PluginMetadata> metadata = identity ? cache().find(*identity, file) : std::nullopt;
        if (!metadata) {
            metadata = scanInChildProcess(scanSettings_.scanner, file, who, scanSettings_.timeout);
            if (identity) cache().store(*identity, *metadata);
        }
        if (metadata->name() != expectedName) {
            throw PluginError(PluginErrorKind::NameMismatch,
                              fmt::format("plugin file {} declares the name '{}', not '{}': rename the file to {} or fix "
                                          "the name in the plugin",
                                          file.string(), metadata->name(), expectedName, pluginFileName(metadata->name())),
                              file);
        }
        record.metadata = std::move(metadata);
        return *record.metadata;
    } catch (const PluginError& e) {
        record.error = e;
        throw;
    }
}

void PluginRegistry::checkNotShadowed(const fs::path& file, std::string_view name,
                                      const std::vector<const PluginMetadata*>& found) const
{
    for (const PluginMetadata* plugin : found) {
        if (plugin->name() != name || canonicalOrSelf(plugin->file()) == canonicalOrSelf(file)) continue;
        throw PluginError(PluginErrorKind::DuplicateName,
                          fmt::format("plugin '{}' ({}): duplicate plugin name: {} was loaded first for the name '{}' and "
                                      "wins; remove one of the two files or reorder the search path ({})",
                                      name, file.string(), plugin->file().string(), name, searchPathHint()),
                          file);
    }
}

const PluginMetadata& PluginRegistry::scan(std::string_view name)
{
    const fs::path file = locate(name);
    struct SaveCache {
        PluginRegistry& registry;
        ~SaveCache() { registry.cache().save(); }
    } save{*this};
    return scanFile(file, name);
}

PluginRegistry::Scan PluginRegistry::scanAll()
{
    Scan result;
    for (const fs::path& dir : searchPath_) {
        for (const fs::path& file : pluginFiles(dir)) {
            const std::string name = nameFromFile(file);
            try {
                checkNotShadowed(file, name, result.plugins);
                const PluginMetadata& plugin = scanFile(file, name);
                if (std::find(result.plugins.begin(), result.plugins.end(), &plugin) == result.plugins.end()) {
                    result.plugins.push_back(&plugin);
                }
            } catch (const PluginError& e) {
                result.errors.push_back(e);
            }
        }
    }
    cache().save();
    return result;
}

const LoadedPlugin& PluginRegistry::load(std::string_view name)
{
    for (const auto& plugin : loaded_)
        if (plugin->name() == name) return *plugin;
    const PluginMetadata& scanned = scan(name);
    const fs::path& file = scanned.file();
    const std::string who = fmt::format("plugin '{}' ({})", name, file.string());
    // The scan loaded this file in the scanner without harm; the same checks run again
    // here, on what this process maps.
    const PenumbraPluginInfo& info = openPluginLibrary(file, who, handles_);
    if (info.name != name) {
        throw PluginError(PluginErrorKind::NameMismatch,
                          fmt::format("plugin file {} declares the name '{}', not '{}' (it changed since it was scanned)",
                                      file.string(), info.name, name),
                          file);
    }
    loaded_.push_back(std::make_unique<LoadedPlugin>(LoadedPlugin{file, &info, pluginShaderDir(info, file)}));
    return *loaded_.back();
}

std::unique_ptr<Technique> PluginRegistry::create(const LoadedPlugin& plugin, const TechniqueSetup& setup,
                                                  const std::string& context) const
{
    const std::string who = fmt::format("plugin '{}' ({})", plugin.name(), context);
    auto failed = [&](const std::string& what) {
        return PluginError(PluginErrorKind::RegistrationFailed, fmt::format("{}: {}", who, what), plugin.file);
    };
    Technique* technique = nullptr;
    try {
        technique = plugin.info->create(setup);
    } catch (const std::exception& e) {
        throw failed(fmt::format("exception during registration: {}", e.what()));
    } catch (...) {
        throw failed("exception during registration (not a std::exception)");
    }
    if (!technique) throw failed("the plugin's factory returned no technique: a bug in the plugin, report it to its author");
    return std::unique_ptr<Technique>(technique);
}

} // namespace penumbra::plugin
