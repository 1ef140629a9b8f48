// `penumbra validate`: what a glTF file or a config holds, every error once with its file and
// JSON path, the lights' plugins loaded with their parameters, and the sweep's variants.
#include "CliTest.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <set>
#include <string>

using namespace penumbra::test;
namespace fs = std::filesystem;

TEST_F(Cli, ValidateReportsWhatAGltfHolds)
{
    const CliResult r = run(fmt::format("validate {}", data("gltf/hierarchy.gltf")));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    // Its two materials, not the scene's default that no mesh uses.
    for (const char* text : {"2 meshes, 3 triangles (6 drawn by 4 instances), 6 nodes, 2 materials, 0 textures, 3 lights",
                             "light 'lamp': spot at (0, 6, 0)", "light 'sun': directional", "light 'bulb': point at (1, 2, 3)",
                             "mesh 0 'quad#0' (/meshes/0/primitives/0): 2 triangles, 4 vertices; nothing to repair",
                             "4 boundary edges, 0 non-manifold triangles",
                             "warning: ", "/meshes/0/primitives/1: 4 vertices (no indices) are not a multiple of 3",
                             "ok: 1 warnings"}) {
        EXPECT_NE(r.out.find(text), std::string::npos) << text << "\n" << r.out;
    }
    // The warnings are listed once, on stdout, not logged again on stderr.
    EXPECT_EQ(r.err, "");
}

TEST_F(Cli, ValidateListsRepairs)
{
    const CliResult r = run(fmt::format("validate {}", data("gltf/non_finite.gltf")));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("2 non-finite triangles dropped, 3 unused vertices removed"), std::string::npos) << r.out;
}

TEST_F(Cli, ValidateGlbWithWeld)
{
    const CliResult r = run(fmt::format("validate --weld {}", data("gltf/quad.glb")));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("1 meshes, 2 triangles"), std::string::npos) << r.out;
}

TEST_F(Cli, ValidateRefusesABrokenGltf)
{
    const CliResult r = run(fmt::format("validate {}", data("gltf/huge_accessor.gltf")));
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("huge_accessor.gltf: /accessors/0: count 4294967295 × 12 bytes exceeds buffer view 0 (128 bytes)"),
              std::string::npos)
        << r.err;
    EXPECT_EQ(r.out, "");
}

TEST_F(Cli, ValidateMissingGltf)
{
    const CliResult r = run(fmt::format("validate '{}/nope.glb'", dir.string()));
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("nope.glb: glTF file not found"), std::string::npos) << r.err;
}

// A glTF model whose buffer lies beside its folder (issue 43): refused by default, read
// once the folder is an allowed root, by --allow-root or the config's scene.allowed_roots.
TEST_F(Cli, AllowRootLetsAModelReadBesideItsFolder)
{
    fs::create_directories(dir / "model");
    fs::create_directories(dir / "shared");
    fs::copy_file(penumbra::test::testDataDir() / "gltf" / "quad.bin", dir / "shared" / "quad.bin");
    nlohmann::json gltf = nlohmann::json::parse(readFile(penumbra::test::testDataDir() / "gltf" / "quad_external.gltf"));
    gltf["buffers"][0]["uri"] = "../shared/quad.bin";
    std::ofstream(dir / "model" / "m.gltf") << gltf.dump();
    const auto config = [&](const std::string& roots) {
        std::ofstream(dir / "c.json") << R"({"scene": {"gltf": "model/m.gltf")" << roots << R"(},
            "camera": {"position": [0, 3, 3], "target": [0, 0, 0]},
            "lights": [{"type": "point", "position": [0, 2, 0], "shadow": {"resolution": 64}}]})";
        return fmt::format("'{}'", (dir / "c.json").string());
    };
    const std::string model = fmt::format("'{}'", (dir / "model" / "m.gltf").string());
    const std::string shared = fmt::format("'{}'", (dir / "shared").string());
    for (const std::string& file : {model, config("")}) {
        const CliResult r = run("validate " + file);
        EXPECT_EQ(r.exitCode, 1) << r.out;
        EXPECT_TRUE(has(r.err, "m.gltf: /buffers/0/uri: \"../shared/quad.bin\": names ")) << r.err;
        EXPECT_EQ(run(fmt::format("validate {} --allow-root {}", file, shared)).exitCode, 0) << file;
    }
    const CliResult r = run("validate " + config(R"(, "allowed_roots": ["shared"])"));
    EXPECT_EQ(r.exitCode, 0) << r.err;
}

TEST_F(Cli, ValidateConfig)
{
    CliResult r = run(fmt::format("validate {}", config("default.json")));
    EXPECT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("config ok"), std::string::npos) << r.out;
    r = run(fmt::format("validate {}", data("configs/malformed.json")));
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("malformed.json: malformed JSON"), std::string::npos) << r.err;
}

TEST_F(Cli, ValidateUnknownFileType)
{
    const CliResult r = run("validate scene.obj");
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("scene.obj: unknown file type '.obj': validate reads .gltf, .glb and .json"), std::string::npos)
        << r.err;
}

// A scene of parts (config/gltf-over-ground.json: a ground generated, a glTF cube of side
// 1 standing on it, and a copy turned 30° about y and scaled 2): validate prints the
// totals and each part's source, transform, counts and bounds after its transform.
TEST_F(Cli, ValidatePrintsEachPartOfAScene)
{
    const CliResult r = run(fmt::format("validate {}", config("gltf-over-ground.json")));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    for (const char* text : {"scene: 3 part(s), 7 meshes, 7 instances, 2270 triangles, 7 materials, 2 textures, bounds (-12, 0, -12) to (12, 2.5, 12)",
                             "  part 0 'ground': generator box-grid, translation (0, 0, 0), rotation (0, 0, 0, 1), scale 1: 5 instances, 2246 triangles",
                             "box-textured.glb, translation (-2, 0.5, 4), rotation (0, 0, 0, 1), scale 1: 1 instances, 12 triangles, "
                             "bounds (-2.5, 0, 3.5) to (-1.5, 1, 4.5)",
                             // Half a side 2 turned 30°: cos 30° + sin 30° = 1.366 about x = 2.5, z = 4.5.
                             "box-textured.glb, translation (2.5, 1, 4.5), rotation_deg (0, 30, 0), scale 2: 1 instances, 12 triangles, "
                             "bounds (1.134, 0, 3.134) to (3.866, 2, 5.866)"}) {
        EXPECT_NE(r.out.find(text), std::string::npos) << text << "\n" << r.out;
    }
}

TEST_F(Cli, ValidateConfigListsSweepVariants)
{
    const CliResult r = run(fmt::format("validate {}", config("sweep-resolution.json")));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("sweep: 8 variants"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("/lights/0/shadow/resolution=4096, /lights/0/shadow/slope_bias=2.0"), std::string::npos) << r.out;
}

TEST_F(Cli, TheTradeoffBenchmarkValidatesWithEveryPlugin)
{
    // config/bench/tradeoff.json (docs/tradeoff.md): every variant's technique loads and
    // takes its parameters; a plugin that failed to load would be a warning.
    const CliResult r = run(fmt::format("validate {}", config("bench/tradeoff.json")));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(r.out.find("sweep: 72 variants") != std::string::npos) << r.out;
    for (const char* variant : {"/scene+/camera+/lights/0/direction=pergola, /lights/0/angular_diameter_deg=6° light, "
                                "/lights/0/shadow=esm",
                                "/scene+/camera+/lights/0/direction=box-grid, grazing sun, "
                                "/lights/0/angular_diameter_deg=1° light, /lights/0/shadow=backprojection",
                                "/scene+/camera+/lights/0/direction=box's foot, /lights/0/angular_diameter_deg=6° light, "
                                "/lights/0/shadow=vssm"}) {
        EXPECT_TRUE(r.out.find(variant) != std::string::npos) << variant << "\n" << r.out;
    }
    EXPECT_EQ(r.out.find("warning:"), std::string::npos) << r.out;
    EXPECT_TRUE(r.out.find("config ok") != std::string::npos) << r.out;
}

TEST_F(Cli, TheGpuCheckBenchHasEveryTechniquePlugin)
{
    // .ci/gpu-check.sh benches config/bench/gpu-check.json: one variant per plugin folder
    // but the reference (the bench's truth), each of which validates.
    const fs::path file = penumbra::test::sourceDir() / "config/bench/gpu-check.json";
    const nlohmann::json doc = nlohmann::json::parse(std::ifstream(file));
    std::set<std::string> benched;
    for (const nlohmann::json& variant : doc.at("sweep").at(0).at("values")) benched.insert(variant.at("technique"));
    std::set<std::string> plugins;
    for (const fs::directory_entry& e : fs::directory_iterator(penumbra::test::sourceDir() / "plugins"))
        if (e.is_directory() && e.path().filename() != "reference") plugins.insert(e.path().filename().string());
    EXPECT_EQ(benched, plugins);
    const CliResult r = run(fmt::format("validate {}", config("bench/gpu-check.json")));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_EQ(r.out.find("warning:"), std::string::npos) << r.out;
}

TEST_F(Cli, ValidateConfigRefusesAMissingGltf)
{
    const fs::path cfg = dir / "cfg.json";
    std::ofstream(cfg) << R"({"scene": {"gltf": "nowhere.glb"}, "camera": {"position": [0, 1, 2], "target": [0, 0, 0]},
        "lights": [{"type": "point", "position": [0, 3, 0]}]})";
    const CliResult r = run(fmt::format("validate '{}'", cfg.string()));
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("cfg.json: /scene/gltf: file not found"), std::string::npos) << r.err;
}

TEST_F(Cli, ValidateLoadsEachLightsPluginWithTheSameDefaultsAsPluginsJson)
{
    const fs::path cfg = dir / "cfg.json";
    std::ofstream(cfg) << testGoodConfig(R"(, "kernel": 9)");
    const CliResult r = run(fmt::format("validate '{}'", cfg.string()), pluginPath());
    ASSERT_EQ(r.exitCode, 0) << r.err;
    // Every value but the one the config sets is the default `plugins --json` lists.
    const nlohmann::json doc = nlohmann::json::parse(run("plugins --json", pluginPath()).out);
    std::string values;
    for (const nlohmann::json& p : doc["plugins"]) {
        if (p["name"] != "testgood") continue;
        for (const nlohmann::json& spec : p["params"]) {
            const std::string name = spec["name"];
            values += fmt::format(" {}={}", name, name == "kernel" ? "9" : spec["default"].dump());
        }
    }
    EXPECT_TRUE(has(r.out, fmt::format("light 0 ('key'): plugin testgood 1.2.0 ({}/penumbra-testgood.so):{}", testPlugins(),
                                       values)))
        << values << "\n" << r.out;
    EXPECT_TRUE(has(r.out, "warning: light 1 ('fill') would render without shadows: plugin 'nosuch': no file "
                           "penumbra-nosuch.so on the plugin search path"))
        << r.out;
    EXPECT_TRUE(has(r.out, "config ok")) << r.out;
}

TEST_F(Cli, ValidateReportsEveryBadParameterWithFileAndJsonPath)
{
    const fs::path cfg = dir / "cfg.json";
    std::ofstream(cfg) << testGoodConfig(R"(, "kernel": 4.5, "mode": "soft", "kernal": 3)");
    const CliResult r = run(fmt::format("validate '{}'", cfg.string()), pluginPath());
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_TRUE(has(r.err, cfg.string() + ": /lights/0/shadow/kernel: must be an integer in [1, 15] (plugin testgood, "
                                          "parameter kernel: a kernel width, unused), got 4.5"))
        << r.err;
    EXPECT_TRUE(has(r.err, cfg.string() + ": /lights/0/shadow/mode: must be one of \"clear\", \"unshadowed\"")) << r.err;
    EXPECT_TRUE(has(r.err, cfg.string() + ": /lights/0/shadow/kernal: plugin 'testgood' has no parameter 'kernal'; did "
                                          "you mean 'kernel'?"))
        << r.err;
    EXPECT_FALSE(has(r.out, "config ok")) << r.out;
}

TEST_F(Cli, ValidateChecksTheParametersOfEverySweepVariant)
{
    const fs::path cfg = dir / "cfg.json";
    std::ofstream(cfg) << testGoodConfig("", R"(, "sweep": [{"path": "/lights/0/shadow/kernel", "values": [3, 40]}])");
    const CliResult r = run(fmt::format("validate '{}'", cfg.string()), pluginPath());
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_TRUE(has(r.out, "sweep: 2 variants")) << r.out;
    // The swept value's own place in the file, then the path it sets.
    EXPECT_TRUE(has(r.err, cfg.string() + " (/sweep/0/values/1): /lights/0/shadow/kernel: must be an integer in [1, 15] "
                                          "(plugin testgood, parameter kernel: a kernel width, unused), got 40"))
        << r.err;
}

TEST_F(Cli, ValidateReportsEachErrorOnceAndEndsWithTheirCount)
{
    // kernel 40 is in two of the four variants, mode "soft" in all: each is one error,
    // naming the variants it is in; the last line counts them, and the exit code is 1.
    const fs::path cfg = dir / "cfg.json";
    std::ofstream(cfg) << testGoodConfig("", R"(, "sweep": [{"path": "/lights/0/shadow/kernel", "values": [3, 40]},
                                                           {"path": "/lights/0/shadow/fill", "values": [0.25, 0.5]},
                                                           {"path": "/lights/0/shadow/mode", "values": ["soft"]}])");
    const CliResult r = run(fmt::format("validate '{}'", cfg.string()), pluginPath());
    EXPECT_EQ(r.exitCode, 1);
    const std::string kernel = cfg.string() + " (/sweep/0/values/1): /lights/0/shadow/kernel: must be an integer in [1, 15]";
    EXPECT_TRUE(has(r.err, kernel)) << r.err;
    EXPECT_EQ(r.err.find(kernel), r.err.rfind(kernel)) << "once: " << r.err;
    EXPECT_TRUE(has(r.err, "got 40 (in variants 3, 4 of 4)\n")) << r.err;
    EXPECT_TRUE(has(r.err, " (/sweep/2/values/0): /lights/0/shadow/mode: must be one of \"clear\", \"unshadowed\"")) << r.err;
    EXPECT_TRUE(has(r.err, "got \"soft\" (in every variant)\n")) << r.err;
    EXPECT_TRUE(r.err.ends_with(cfg.string() + ": 2 errors\n")) << r.err;
    EXPECT_TRUE(has(r.out, "  variant 3: /lights/0/shadow/kernel=40, /lights/0/shadow/fill=0.25, /lights/0/shadow/mode=\"soft\"\n"))
        << r.out;
    EXPECT_FALSE(has(r.out, "config ok")) << r.out;

    // A --set error is the run's own, whichever variants it is found in: one error.
    std::ofstream(cfg) << testGoodConfig("", R"(, "sweep": [{"path": "/lights/0/shadow/fill", "values": [0.25, 0.5]}])");
    const CliResult set = run(fmt::format("validate '{}' --set testgood.kernel=99", cfg.string()), pluginPath());
    EXPECT_EQ(set.exitCode, 1);
    const std::string bad = "penumbra: error: --set testgood.kernel: must be an integer in [1, 15] (plugin testgood, "
                            "parameter kernel: a kernel width, unused), got 99\n";
    EXPECT_TRUE(has(set.err, bad)) << set.err;
    EXPECT_EQ(set.err.find(bad), set.err.rfind(bad)) << "once: " << set.err;
    EXPECT_TRUE(set.err.ends_with(cfg.string() + ": 1 error\n")) << set.err;
}

TEST_F(Cli, ValidateAppliesASetToTheVariantsThatUseItsTechnique)
{
    // As bench does: light 0 is testgood in one variant, nosuch in the other.
    const fs::path cfg = dir / "cfg.json";
    std::ofstream(cfg) << testGoodConfig(R"(, "required": false)",
                                         R"(, "sweep": [{"path": "/lights/0/shadow/technique", "values": ["testgood", "nosuch"]}])");
    CliResult r = run(fmt::format("validate '{}' --set testgood.kernel=5", cfg.string()), pluginPath());
    EXPECT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(has(r.out, "config ok")) << r.out;
    const size_t warning = r.out.find("warning: light 0 ('key') would render without shadows: plugin 'nosuch'");
    ASSERT_NE(warning, std::string::npos) << r.out;
    const std::string line = r.out.substr(warning, r.out.find('\n', warning) - warning);
    EXPECT_TRUE(line.ends_with(" (in variant 2 of 2)")) << line;
    r = run(fmt::format("validate '{}' --set other.kernel=5", cfg.string()), pluginPath());
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_TRUE(has(r.err, "--set other.kernel: no light of any sweep variant uses technique 'other'")) << r.err;
    EXPECT_TRUE(r.err.ends_with(": 1 error\n")) << r.err;
}

// A misspelt technique is an error in validate and render alike, naming where the config
// says it and the closest plugin name, unless the light says "required": false.
TEST_F(Cli, AnUnknownTechniqueIsAnErrorUnlessTheLightMayGoWithout)
{
    const fs::path cfg = dir / "cfg.json";
    const auto write = [&](const std::string& shadow) {
        std::ofstream(cfg, std::ios::trunc) << fmt::format(R"({{"camera": {{"position": [0, 5, 10], "target": [0, 0, 0]}},
            "lights": [{{"name": "key", "type": "point", "position": [0, 4, 0], "shadow": {}}}]}})", shadow);
    };
    write(R"({"technique": "pcsss"})");
    CliResult r = run(fmt::format("validate '{}'", cfg.string()));
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_TRUE(has(r.err, cfg.string() + ": /lights/0/shadow/technique: light 0 ('key'): technique 'pcsss' cannot be used"))
        << r.err;
    EXPECT_TRUE(has(r.err, "did you mean 'pcss'?")) << r.err;
    EXPECT_TRUE(has(r.err, "plugins there: ")) << r.err;
    r = run(fmt::format("render '{}' -o '{}' --width 16 --height 16", cfg.string(), (dir / "out.png").string()));
    EXPECT_EQ(r.exitCode, 1);
    // In validate's words: render checks the lights' plugins before the device starts.
    EXPECT_TRUE(has(r.err, "/lights/0/shadow/technique: light 0 ('key'): technique 'pcsss' cannot be used")) << r.err;
    EXPECT_TRUE(has(r.err, "plugin 'pcsss': no file penumbra-pcsss.so")) << r.err;
    EXPECT_FALSE(fs::exists(dir / "out.png"));

    write(R"({"technique": "pcsss", "required": false})");
    r = run(fmt::format("validate '{}'", cfg.string()));
    EXPECT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(has(r.out, "warning: light 0 ('key') would render without shadows: plugin 'pcsss'")) << r.out;
    EXPECT_TRUE(has(r.out, "config ok")) << r.out;
}

TEST_F(Cli, ValidateRequiredPluginThatCannotLoadIsAnError)
{
    const fs::path cfg = dir / "cfg.json";
    std::ofstream(cfg) << R"({"camera": {"position": [0, 5, 10], "target": [0, 0, 0]},
        "lights": [{"name": "key", "type": "point", "position": [0, 4, 0], "shadow": {"technique": "nodep", "required": true}}]})";
    const CliResult r = run(fmt::format("validate '{}'", cfg.string()), pluginPath());
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_TRUE(has(r.err, "light 0 ('key'): required technique 'nodep' cannot be used: plugin 'nodep' (")) << r.err;
    EXPECT_TRUE(has(r.err, "libpenumbra_test_absent.so: cannot open shared object file")) << r.err;
}

TEST_F(Cli, AMisspelledShadowKeyGetsADidYouMeanFromTheConfigReader)
{
    const fs::path cfg = dir / "typo.json";
    std::ofstream(cfg) << R"({"camera": {"position": [0, 5, 10], "target": [0, 0, 0]},
        "lights": [{"type": "spot", "position": [0, 10, 0], "target": [0, 0, 0], "shadow": {"technque": "pcss"}}]})";
    const CliResult r = run(fmt::format("validate '{}'", cfg.string()));
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_TRUE(has(r.err, "typo.json: /lights/0/shadow/technque: unknown key; did you mean \"technique\"?")) << r.err;
    EXPECT_FALSE(has(r.err, "plugin 'hard'")) << r.err;
}
