#include "PluginsCommand.h"

#include "penumbra/core/Error.h"
#include "penumbra/plugin/Params.h"
#include "penumbra/plugin/PluginRegistry.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <memory>

using nlohmann::json;
namespace fs = std::filesystem;

namespace penumbra::app {
namespace {

struct PluginsFlags {
    bool json = false;
    bool strict = false;
    std::vector<std::string> path;  // searched first, before the default search path
};

// "5 in [1, 15] texels", "3 odd in [1, 15] texels", "true", "clear of clear|unshadowed": a
// spec's default and what it may be, from its JSON form so that text and --json agree.
std::string describeValues(const plugin::ParamSpec& spec)
{
    const json j = plugin::specToJson(spec);
    const auto text = [](const json& v) { return v.is_string() ? v.get<std::string>() : v.dump(); };
    std::string out = text(j["default"]);
    if (j.contains("min"))
        out += fmt::format("{} in [{}, {}]", j.value("odd", false) ? " odd" : "", j["min"].dump(), j["max"].dump());
    if (j.contains("choices")) out += fmt::format(" of {}", fmt::join(j["choices"].get<std::vector<std::string>>(), "|"));
    if (spec.unit[0]) out += fmt::format(" {}", spec.unit);
    return out;
}

void printPlugin(const plugin::PluginMetadata& p)
{
    fmt::print("{} {}: {}\n", p.name(), p.version(), p.summary());
    fmt::print("  file:    {}\n", p.file().string());
    fmt::print("  shaders: {}\n", p.shaderDir().string());
    if (p.params().empty()) {
        fmt::print("  no parameters\n");
        return;
    }
    size_t nameWidth = 0, valuesWidth = 0;
    for (const plugin::ParamSpec& spec : p.params()) {
        nameWidth = std::max(nameWidth, std::string_view(spec.name).size());
        valuesWidth = std::max(valuesWidth, describeValues(spec).size());
    }
    fmt::print("  parameters:\n");
    for (const plugin::ParamSpec& spec : p.params()) {
        fmt::print("    {:<{}}  {:<5}  {:<{}}  {}\n", spec.name, nameWidth, plugin::paramTypeName(spec.type),
                   describeValues(spec), valuesWidth, spec.doc);
    }
}

int runPlugins(const PluginsFlags& flags)
{
    std::vector<fs::path> searchPath(flags.path.begin(), flags.path.end());
    for (fs::path& dir : plugin::defaultPluginSearchPath()) searchPath.push_back(std::move(dir));
    plugin::PluginRegistry registry(searchPath);
    // Scanned, each in the plugin scanner's process: nothing of a plugin runs here.
    const plugin::PluginRegistry::Scan found = registry.scanAll();

    if (flags.json) {
        json doc = {{"abi", PENUMBRA_PLUGIN_ABI_VERSION}, {"search_path", json::array()}, {"plugins", json::array()},
                    {"errors", json::array()}};
        for (const fs::path& dir : registry.searchPath()) doc["search_path"].push_back(dir.string());
        for (const plugin::PluginMetadata* p : found.plugins) doc["plugins"].push_back(p->toJson());
        for (const plugin::PluginError& e : found.errors) {
            doc["errors"].push_back(
                {{"file", e.file().string()}, {"kind", plugin::pluginErrorKindName(e.kind())}, {"message", e.what()}});
        }
        // Messages quote damaged files' strings (dlerror does), which need not be UTF-8.
        fmt::print("{}\n", doc.dump(2, ' ', false, json::error_handler_t::replace));
    } else {
        std::vector<std::string> folders;
        for (const fs::path& dir : registry.searchPath()) folders.push_back(dir.string());
        fmt::print("plugin search path: {} (plugin ABI {})\n", folders.empty() ? "empty" : fmt::format("{}", fmt::join(folders, ":")),
                   PENUMBRA_PLUGIN_ABI_VERSION);
        for (const plugin::PluginMetadata* p : found.plugins) {
            fmt::print("\n");
            printPlugin(*p);
        }
        fmt::print("\n{} plugin(s), {} file(s) failed to load\n", found.plugins.size(), found.errors.size());
        for (const plugin::PluginError& e : found.errors) {
            fmt::print("error [{}]: {}\n", plugin::pluginErrorKindName(e.kind()), e.what());
        }
        if (found.plugins.empty() && found.errors.empty()) {
            fmt::print("no penumbra-<name>.so files there: build the plugins, or add their folder to "
                       "PENUMBRA_PLUGIN_PATH or --path\n");
        }
    }
    return flags.strict && !found.errors.empty() ? 1 : 0;
}

} // namespace

Command addPluginsCommand(CLI::App& app)
{
    auto flags = std::make_shared<PluginsFlags>();
    CLI::App* cmd = app.add_subcommand("plugins", "List the technique plugins on the search path with their parameters, "
                                                  "and every plugin file that fails to load with the reason");
    cmd->add_flag("--json", flags->json, "Print a JSON document: {abi, search_path, plugins, errors}");
    cmd->add_option("--path", flags->path,
                    "Also search this folder, before $PENUMBRA_PLUGIN_PATH and the build and install trees (repeatable)")
        ->check(CLI::ExistingDirectory)
        ->allow_extra_args(false);
    cmd->add_flag("--strict", flags->strict, "Exit 1 when any plugin file fails to load (default: list it, exit 0)");
    return {cmd, [flags] { return runPlugins(*flags); }};
}

} // namespace penumbra::app
