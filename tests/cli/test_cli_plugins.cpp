// `penumbra plugins`: every plugin on the search path with its parameters, and every file
// that failed to load with the reason, as text and JSON; a plugin that crashes the scanner.
#include "CliTest.h"

#include "penumbra/plugin/Plugin.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <map>
#include <string>

using namespace penumbra::test;
namespace fs = std::filesystem;

TEST_F(Cli, PluginsListsEveryPluginWithItsParametersAndEveryFailure)
{
    const CliResult r = run("plugins", pluginPath());
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(has(r.out, fmt::format("plugin search path: {}:{}", testPlugins(), shadowedPlugins()))) << r.out;
    EXPECT_TRUE(has(r.out, "testgood 1.2.0: test plugin: clears V_l to a constant")) << r.out;
    EXPECT_TRUE(has(r.out, fmt::format("  file:    {}/penumbra-testgood.so", testPlugins()))) << r.out;
    for (const char* line : {"enabled  bool   true", "kernel   int    5 in [1, 15] texels", "a kernel width, unused",
                             "fill     float  0.5 in [0.0, 1.0]", "bias     float  0.01 in [-1.0, 1.0] world",
                             "mode     enum   clear of clear|unshadowed", "clear to fill, or to 1 (unshadowed)"}) {
        EXPECT_TRUE(has(r.out, line)) << line << "\n" << r.out;
    }
    // The build tree's own plugins (hard, ...) follow on the default path; the count of
    // failures is the test folders' alone.
    EXPECT_TRUE(has(r.out, "hard ")) << r.out;
    EXPECT_TRUE(has(r.out, "3 odd in [1, 15] texels")) << r.out;  // hard's pcf_kernel: ParamSpec::odd
    EXPECT_TRUE(has(r.out, " plugin(s), 7 file(s) failed to load")) << r.out;
    EXPECT_TRUE(has(r.out, "error [abi-mismatch]: plugin 'abi'")) << r.out;
    EXPECT_TRUE(has(r.out, "built for plugin ABI 9999, this engine has ABI " +
                               std::to_string(PENUMBRA_PLUGIN_ABI_VERSION)))
        << r.out;
    EXPECT_TRUE(has(r.out, "error [dependency-missing]: plugin 'nodep'")) << r.out;
    EXPECT_TRUE(has(r.out, "libpenumbra_test_absent.so: cannot open shared object file")) << r.out;
    EXPECT_TRUE(has(r.out, "error [not-a-library]: plugin 'garbage'")) << r.out;
    EXPECT_TRUE(has(r.out, "error [duplicate-name]: plugin 'dup' (" + shadowedPlugins())) << r.out;
}

TEST_F(Cli, PluginsStrictFailsWhenAFileFailsToLoad)
{
    EXPECT_EQ(run("plugins --strict", pluginPath()).exitCode, 1);
    EXPECT_EQ(run("plugins", pluginPath()).exitCode, 0);
}

TEST_F(Cli, PluginsJsonDescribesSpecsAndErrors)
{
    const CliResult r = run("plugins --json", pluginPath());
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const nlohmann::json doc = nlohmann::json::parse(r.out);
    EXPECT_EQ(doc["abi"], PENUMBRA_PLUGIN_ABI_VERSION);
    EXPECT_EQ(doc["search_path"][0], testPlugins());
    EXPECT_EQ(doc["search_path"][1], shadowedPlugins());
    std::map<std::string, nlohmann::json> plugins;
    for (const nlohmann::json& p : doc["plugins"]) plugins[p["name"].get<std::string>()] = p;
    ASSERT_TRUE(plugins.count("testgood")) << r.out;
    const nlohmann::json& good = plugins["testgood"];
    EXPECT_EQ(good["version"], "1.2.0");
    EXPECT_EQ(good["abi"], PENUMBRA_PLUGIN_ABI_VERSION);
    EXPECT_EQ(good["file"], testPlugins() + "/penumbra-testgood.so");
    EXPECT_EQ(good["summary"], "test plugin: clears V_l to a constant");
    EXPECT_EQ(good["params"], nlohmann::json::parse(R"json([
        {"name": "enabled", "type": "bool", "default": true, "unit": "", "doc": "register the clear pass at all"},
        {"name": "kernel", "type": "int", "default": 5, "min": 1, "max": 15, "unit": "texels", "doc": "a kernel width, unused"},
        {"name": "fill", "type": "float", "default": 0.5, "min": 0.0, "max": 1.0, "unit": "", "doc": "the value V_l is cleared to"},
        {"name": "bias", "type": "float", "default": 0.01, "min": -1.0, "max": 1.0, "unit": "world", "doc": "a signed offset, unused"},
        {"name": "mode", "type": "enum", "default": "clear", "choices": ["clear", "unshadowed"], "unit": "",
         "doc": "clear to fill, or to 1 (unshadowed)"}])json"));
    EXPECT_EQ(plugins["dup"]["version"], "1.0") << "the first folder on the path wins";

    std::map<std::string, std::string> kinds;
    for (const nlohmann::json& e : doc["errors"]) {
        EXPECT_TRUE(has(e["message"].get<std::string>(), e["file"].get<std::string>())) << e.dump();
        kinds[e["file"].get<std::string>()] = e["kind"].get<std::string>();
    }
    EXPECT_EQ(kinds, (std::map<std::string, std::string>{
                         {testPlugins() + "/penumbra-abi.so", "abi-mismatch"},
                         {testPlugins() + "/penumbra-badinfo.so", "invalid-info"},
                         {testPlugins() + "/penumbra-garbage.so", "not-a-library"},
                         {testPlugins() + "/penumbra-mismatch.so", "name-mismatch"},
                         {testPlugins() + "/penumbra-nodep.so", "dependency-missing"},
                         {testPlugins() + "/penumbra-noentry.so", "entry-missing"},
                         {shadowedPlugins() + "/penumbra-dup.so", "duplicate-name"},
                     }));
}

TEST_F(Cli, PluginsPathFlagIsSearchedFirst)
{
    const CliResult r = run(fmt::format("plugins --json --path '{}'", shadowedPlugins()),
                            fmt::format("PENUMBRA_PLUGIN_PATH='{}'", testPlugins()));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const nlohmann::json doc = nlohmann::json::parse(r.out);
    for (const nlohmann::json& p : doc["plugins"]) {
        if (p["name"] == "dup") {
            EXPECT_EQ(p["version"], "2.0") << "--path is searched first";
        }
    }
    bool shadowedFirst = false;
    for (const nlohmann::json& e : doc["errors"])
        shadowedFirst |= e["kind"] == "duplicate-name" && e["file"] == testPlugins() + "/penumbra-dup.so";
    EXPECT_TRUE(shadowedFirst) << r.out;

    const CliResult missing = run(fmt::format("plugins --path '{}/nowhere'", dir.string()));
    EXPECT_NE(missing.exitCode, 0);
    EXPECT_TRUE(has(missing.err, "nowhere")) << missing.err;
}

// A plugin whose loading crashes (SIGSEGV in its entry point) kills the plugin scanner, not
// penumbra: `plugins` lists it as an error (exit 0; --strict 1), render with it exits 1
// naming the plugin and the signal.
TEST_F(Cli, APluginThatCrashesWhileLoadingIsReportedNotACrash)
{
    fs::create_directories(dir / "plugins");
    fs::create_symlink(penumbra::test::crashingTestPluginDir() / "penumbra-crashes.so", dir / "plugins" / "penumbra-crashes.so");
    const std::string env = fmt::format("PENUMBRA_PLUGIN_PATH='{}'", (dir / "plugins").string());
    // A scanner built with AddressSanitizer (the sanitizer build's, like this test) reports
    // the SIGSEGV and aborts (abort_on_error): the signal it dies of is then SIGABRT.
#ifdef __SANITIZE_ADDRESS__
    const std::string died = "the plugin scanner died of SIGABRT";
#else
    const std::string died = "the plugin scanner died of SIGSEGV";
#endif
    CliResult r = run("plugins", env);
    EXPECT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(has(r.out, "error [scan-failed]: plugin 'crashes' (")) << r.out;
    EXPECT_TRUE(has(r.out, died)) << r.out;
    EXPECT_EQ(run("plugins --strict", env).exitCode, 1);

    const fs::path cfg = dir / "cfg.json";
    std::ofstream(cfg) << R"({"camera": {"position": [0, 5, 10], "target": [0, 0, 0]},
        "lights": [{"name": "key", "type": "point", "position": [0, 4, 0], "shadow": {"technique": "crashes"}}]})";
    r = run(fmt::format("render '{}' -o '{}' --width 16 --height 16", cfg.string(), (dir / "out.png").string()), env);
    EXPECT_EQ(r.exitCode, 1) << r.err;
    EXPECT_TRUE(has(r.err, "plugin 'crashes' (")) << r.err;
    EXPECT_TRUE(has(r.err, died)) << r.err;
    EXPECT_FALSE(fs::exists(dir / "out.png"));
}

// A plugin scan cache that cannot be read is ignored with a warning, and rewritten.
TEST_F(Cli, ACorruptPluginScanCacheIsIgnoredWithAWarning)
{
    const fs::path cache = dir / "cache" / "penumbra" / fmt::format("plugin-scan-{}.json", PENUMBRA_PLUGIN_ABI_VERSION);
    fs::create_directories(cache.parent_path());
    std::ofstream(cache) << "not json";
    const CliResult r = run("plugins --json", fmt::format("XDG_CACHE_HOME='{}' {}", (dir / "cache").string(), pluginPath()));
    EXPECT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(has(r.err, "warning: " + cache.string() + ": ignoring the plugin scan cache")) << r.err;
    EXPECT_FALSE(nlohmann::json::parse(r.out)["plugins"].empty());
    EXPECT_FALSE(nlohmann::json::parse(readFile(cache))["entries"].empty()) << "rewritten";
}
