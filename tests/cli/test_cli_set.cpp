// --set technique.parameter=value, which render, graph, compare, bench and validate take:
// checked against the plugin's parameters before the device starts.
#include "CliTest.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

using namespace penumbra::test;
namespace fs = std::filesystem;

TEST_F(Cli, SetOverridesTheConfigsParameters)
{
    const fs::path cfg = dir / "cfg.json";
    std::ofstream(cfg) << testGoodConfig(R"(, "kernel": 9)");
    const CliResult r = run(fmt::format("validate '{}' --set testgood.kernel=11 --set testgood.mode=unshadowed "
                                        "--set 'testgood.fill=0.25'",
                                        cfg.string()),
                            pluginPath());
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(has(r.out, "enabled=true kernel=11 fill=0.25 bias=0.01 mode=\"unshadowed\"")) << r.out;
}

TEST_F(Cli, SetWithABadValueNamesTheFlag)
{
    const fs::path cfg = dir / "cfg.json";
    std::ofstream(cfg) << testGoodConfig("");
    const CliResult r = run(fmt::format("validate '{}' --set testgood.kernel=99", cfg.string()), pluginPath());
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_TRUE(has(r.err, "--set testgood.kernel: must be an integer in [1, 15] (plugin testgood, parameter kernel: a "
                           "kernel width, unused), got 99"))
        << r.err;
    const CliResult unknown = run(fmt::format("validate '{}' --set testgood.kernl=3", cfg.string()), pluginPath());
    EXPECT_EQ(unknown.exitCode, 1);
    EXPECT_TRUE(has(unknown.err, "--set testgood.kernl: plugin 'testgood' has no parameter 'kernl'; did you mean 'kernel'?"))
        << unknown.err;
}

TEST_F(Cli, SetForATechniqueNoLightUsesOrWithBadSyntaxFailsBeforeRendering)
{
    CliResult r = run(fmt::format("render {} -o '{}/out.png' --set nosuch.size=1", config("default.json"), dir.string()),
                      pluginPath());
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_TRUE(has(r.err, "--set nosuch.size: no light of ")) << r.err;
    EXPECT_TRUE(has(r.err, "default.json uses technique 'nosuch' (its lights use: hard")) << r.err;
    EXPECT_FALSE(fs::exists(dir / "out.png"));

    r = run(fmt::format("render {} -o '{}/out.png' --set hard.size", config("default.json"), dir.string()));
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_TRUE(has(r.err, "--set 'hard.size': expected technique.parameter=value, e.g. --set hard.pcf_kernel=5")) << r.err;
    EXPECT_FALSE(fs::exists(dir / "out.png"));

    r = run(fmt::format("validate {} --set hard.size=1", data("gltf/quad.glb")));
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_TRUE(has(r.err, "quad.glb: --set sets technique parameters of a config (.json), not of a glTF file")) << r.err;
}

// A device that does not exist fails only once the device is chosen: an error about a
// --set (or an image name) instead shows that it came first.
TEST_F(Cli, SetErrorsComeBeforeTheDeviceStarts)
{
    const std::string noDevice = "--device no-such-gpu";
    for (const std::string& command : {fmt::format("render {} -o '{}/out.png'", config("default.json"), dir.string()),
                                       fmt::format("graph {}", config("default.json")),
                                       fmt::format("compare {}", config("default.json"))}) {
        SCOPED_TRACE(command);
        CliResult r = run(fmt::format("{} {} --set hard.pcf_kernl=3", command, noDevice));
        EXPECT_EQ(r.exitCode, 1);
        EXPECT_TRUE(has(r.err, "--set hard.pcf_kernl: plugin 'hard' has no parameter 'pcf_kernl'; did you mean 'pcf_kernel'?"))
            << r.err;
        EXPECT_FALSE(has(r.err, "no suitable device")) << r.err;
        r = run(fmt::format("{} {} --set nosuch.size=1", command, noDevice));
        EXPECT_EQ(r.exitCode, 1);
        EXPECT_TRUE(has(r.err, "--set nosuch.size: no light of ")) << r.err;
        EXPECT_FALSE(has(r.err, "no suitable device")) << r.err;
    }
    EXPECT_FALSE(fs::exists(dir / "out.png"));
}
