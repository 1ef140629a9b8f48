// `penumbra compare`: a config's frame against a reference render (figures by region, images,
// the float visibility), or two EXR files channel by channel.
#include "CliTest.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <vector>

using namespace penumbra::test;
namespace fs = std::filesystem;

namespace {

// testGoodConfig at 64 x 48: light 'key' clears V to `fill` (testgood), light 'fill'
// names a plugin that exists nowhere and renders unshadowed (V = 1).
std::string compareConfig(const std::string& fill)
{
    return testGoodConfig(fmt::format(R"(, "fill": {})", fill), R"(, "output": {"width": 64, "height": 48})");
}

} // namespace

TEST_F(Cli, CompareGivesExactFiguresForConstantVisibility)
{
    const fs::path cfg = dir / "cfg.json";
    std::ofstream(cfg) << compareConfig("0.25");
    const CliResult r = run(fmt::format("compare '{}' {} --json --validation", cfg.string(), kTestGoodReference), pluginPath());
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const nlohmann::json doc = nlohmann::json::parse(r.out);
    EXPECT_EQ(doc["width"], 64);
    EXPECT_EQ(doc["height"], 48);
    EXPECT_EQ(doc["reference"]["technique"], "testgood");
    EXPECT_EQ(doc["reference"]["params"]["fill"], 0.75);
    ASSERT_EQ(doc["lights"].size(), 2u);

    // |0.25 - 0.75| = 0.5 on every pixel of geometry, all of it penumbra of the reference,
    // up to V_l's 16-bit storage (kVStep).
    const nlohmann::json& key = doc["lights"][0];
    EXPECT_EQ(key["name"], "key");
    EXPECT_EQ(key["technique"], "testgood");
    EXPECT_EQ(key["params"]["fill"], 0.25);
    const nlohmann::json& v = key["visibility"];
    const int geometry = v["geometry_pixels"].get<int>();
    EXPECT_GT(geometry, 0);
    EXPECT_LT(geometry, 64 * 48) << "the sky is background and not compared";
    EXPECT_EQ(v["all"]["pixels"], geometry);
    EXPECT_NEAR(v["all"]["rmse"].get<double>(), 0.5, kVStep);
    EXPECT_NEAR(v["all"]["mae"].get<double>(), 0.5, kVStep);
    EXPECT_NEAR(v["all"]["max_abs_error"].get<double>(), 0.5, kVStep);
    EXPECT_EQ(v["all"]["above"][0]["percent"], 100.0);
    EXPECT_EQ(v["all"]["above"][1]["percent"], 100.0);
    EXPECT_EQ(v["regions"]["penumbra"]["pixels"], geometry);
    EXPECT_EQ(v["regions"]["umbra"]["pixels"], 0);
    EXPECT_TRUE(v["regions"]["umbra"]["max_at"].is_null());
    // Constant images: SSIM is the luminance term (2ab + C1) / (a² + b² + C1), C1 = 1e-4.
    EXPECT_NEAR(v["ssim"].get<double>(), (2 * 0.25 * 0.75 + 1e-4) / (0.25 * 0.25 + 0.75 * 0.75 + 1e-4), 1e-4);

    // The light whose plugin is missing rendered unshadowed: V = 1 against 0.75.
    const nlohmann::json& fill = doc["lights"][1];
    EXPECT_EQ(fill["technique"], "unshadowed");
    EXPECT_TRUE(fill["params"].is_null());
    EXPECT_NEAR(fill["visibility"]["all"]["rmse"].get<double>(), 0.25, kVStep);
    EXPECT_TRUE(has(doc["warnings"].dump(), "test render: light 1: rendered without shadows: plugin 'nosuch'")) << doc.dump();

    EXPECT_EQ(doc["color"]["geometry_pixels"], geometry);
    EXPECT_GT(doc["color"]["all"]["rmse"].get<double>(), 0.0) << "less light reaches the test image";
    EXPECT_FALSE(doc.contains("files"));
}

TEST_F(Cli, ComparePrintsATableByRegion)
{
    const fs::path cfg = dir / "cfg.json";
    std::ofstream(cfg) << compareConfig("0.25");
    const CliResult r = run(fmt::format("compare '{}' {}", cfg.string(), kTestGoodReference), pluginPath());
    ASSERT_EQ(r.exitCode, 0) << r.err;
    for (const char* line : {"reference technique testgood", "regions of the reference: umbra V <= 0.01, lit V >= 0.99",
                             "light 0 'key': testgood", "light 1 'fill': unshadowed", "region       pixels      RMSE",
                             "SSIM 0.600", "colour (sRGB values in [0, 1], averaged over R, G, B)", "SSIM (luma)"}) {
        EXPECT_TRUE(has(r.out, line)) << line << "\n" << r.out;
    }
    EXPECT_TRUE(has(r.out, "  umbra             0   0.00000   0.00000   0.00000            -    0.00%    0.00%")) << r.out;
    // 0.5 less half a step of V_l's 16 bits: 0.75 and 0.25 are stored as 49151 and 16384 / 65535.
    EXPECT_TRUE(has(r.out, "0.49999   0.49999   0.49999")) << r.out;
}

TEST_F(Cli, CompareWritesEveryImageAndLeavesOtherFilesAlone)
{
    const fs::path cfg = dir / "cfg.json";
    std::ofstream(cfg) << compareConfig("0.25");
    const fs::path out = dir / "out";
    fs::create_directories(out);
    std::ofstream(out / "notes.txt") << "mine";
    std::ofstream(out / "key.test.png") << "an older run";
    const CliResult r = run(fmt::format("compare '{}' {} -o '{}/' --json", cfg.string(), kTestGoodReference, out.string()),
                            pluginPath());
    ASSERT_EQ(r.exitCode, 0) << r.err;

    std::set<std::string> names;
    for (const auto& entry : fs::directory_iterator(out)) names.insert(entry.path().filename().string());
    EXPECT_EQ(names, (std::set<std::string>{"notes.txt", "key.test.png", "key.reference.png", "key.diff.png", "fill.test.png",
                                            "fill.reference.png", "fill.diff.png", "color.test.png", "color.reference.png",
                                            "visibility.test.exr", "visibility.reference.exr", "metrics.json"}))
        << "no temporary file is left";
    EXPECT_EQ(readFile(out / "notes.txt"), "mine");

    const nlohmann::json metrics = nlohmann::json::parse(readFile(out / "metrics.json"));
    EXPECT_EQ(metrics, nlohmann::json::parse(r.out)) << "metrics.json is what --json prints";
    EXPECT_EQ(metrics["lights"][0]["files"]["diff"], "key.diff.png");
    EXPECT_EQ(metrics["color"]["files"]["test"], "color.test.png");

    // Greyscale V: round(255 V). The pixel of the largest error is one of geometry.
    const int x = metrics["lights"][0]["visibility"]["all"]["max_at"]["x"], y = metrics["lights"][0]["visibility"]["all"]["max_at"]["y"];
    const Rgba8Image test = readImage(out / "key.test.png"), reference = readImage(out / "key.reference.png");
    ASSERT_EQ(test.width, 64);
    ASSERT_EQ(test.height, 48);
    EXPECT_EQ(test.at(x, y), (std::vector<int>{64, 64, 64, 255}));
    EXPECT_EQ(reference.at(x, y), (std::vector<int>{191, 191, 191, 255}));
    // Difference: too dark by 0.5 = the default full scale: the darkest blue; the
    // unshadowed light too lit by 0.25: halfway along the red stops; background grey.
    EXPECT_EQ(readImage(out / "key.diff.png").at(x, y), (std::vector<int>{5, 48, 97, 255}));
    const Rgba8Image fillDiff = readImage(out / "fill.diff.png");
    EXPECT_EQ(fillDiff.at(x, y), (std::vector<int>{229, 130, 103, 255}));  // 0.25 as stored in 16 bits
    EXPECT_EQ(fillDiff.at(0, 0), (std::vector<int>{128, 128, 128, 255})) << "the top-left corner is sky";
    const Rgba8Image color = readImage(out / "color.test.png");
    EXPECT_EQ(color.width, 64);
}

TEST_F(Cli, CompareRendersARealTechniqueAgainstAFilteredOne)
{
    const fs::path out = dir / "out";
    const CliResult r = run(fmt::format("compare {} --width 160 --height 90 --set hard.resolution=512 --reference hard "
                                        "--reference-set filter=poisson --reference-set hard.filter_radius=4 --json "
                                        "--validation -o '{}'",
                                        config("default.json"), out.string()));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const nlohmann::json doc = nlohmann::json::parse(r.out);
    EXPECT_EQ(doc["reference"]["params"]["filter"], "poisson");
    EXPECT_EQ(doc["reference"]["params"]["resolution"], 2048) << "the reference does not take the test's --set";
    EXPECT_EQ(doc["lights"][0]["params"]["resolution"], 512);
    const nlohmann::json& v = doc["lights"][0]["visibility"];
    // An unfiltered map against a filtered one: they differ at shadow edges only.
    EXPECT_GT(v["all"]["rmse"].get<double>(), 0.01);
    EXPECT_LT(v["all"]["rmse"].get<double>(), 0.3);
    EXPECT_GT(v["regions"]["penumbra"]["rmse"].get<double>(), v["regions"]["lit"]["rmse"].get<double>());
    int regionPixels = 0;
    for (const char* region : {"umbra", "penumbra", "lit"}) regionPixels += v["regions"][region]["pixels"].get<int>();
    EXPECT_EQ(regionPixels, v["all"]["pixels"].get<int>());
    EXPECT_GT(v["ssim"].get<double>(), 0.5);
    EXPECT_LT(v["ssim"].get<double>(), 1.0);
    EXPECT_TRUE(fs::exists(out / "light0.diff.png"));
}

// Float output (issue 19): compare -o writes every light's V of both renders as 32-bit
// floats, one channel "<light name>.V" per light, and they are the values the figures
// come from: the RMSE over the pixels of geometry, recomputed from the two files (pixels
// without geometry hold 1 in both), is the reported one.
TEST_F(Cli, CompareWritesTheFloatVisibilityItsFiguresComeFrom)
{
    const fs::path out = dir / "out";
    const CliResult r = run(fmt::format("compare {} --width 160 --height 90 --set hard.resolution=512 --reference hard "
                                        "--reference-set filter=poisson --reference-set hard.filter_radius=4 --json "
                                        "-o '{}'",
                                        config("two-spots.json"), out.string()));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const nlohmann::json doc = nlohmann::json::parse(r.out);
    EXPECT_EQ(doc["visibility_files"]["test"], "visibility.test.exr");
    const Exr test = readExr(out / "visibility.test.exr"), reference = readExr(out / "visibility.reference.exr");
    ASSERT_EQ(test.width, 160);
    ASSERT_EQ(test.height, 90);
    ASSERT_EQ(test.channels.size(), doc["lights"].size() + 1) << "a channel per light, and Y";
    EXPECT_EQ(test.channels.at("Y"), test.channels.at(doc["lights"][0]["files"]["channel"].get<std::string>()))
        << "Y is the first light's V";
    for (const nlohmann::json& light : doc["lights"]) {
        const std::string channel = light["files"]["channel"];
        EXPECT_EQ(channel, light["name"].get<std::string>() + ".V");
        ASSERT_TRUE(test.channels.count(channel) && reference.channels.count(channel)) << channel;
        const std::vector<float>& v = test.channels.at(channel);
        const std::vector<float>& vRef = reference.channels.at(channel);
        double squared = 0.0;
        size_t shadowed = 0;
        for (size_t i = 0; i < v.size(); ++i) {
            squared += (double(v[i]) - vRef[i]) * (double(v[i]) - vRef[i]);
            shadowed += v[i] < 0.5f ? 1 : 0;
        }
        EXPECT_GT(shadowed, 100u) << channel;
        EXPECT_EQ(v[0], 1.0f) << "the top-left corner is sky";
        const nlohmann::json& all = light["visibility"]["all"];
        const double rmse = std::sqrt(squared / all["pixels"].get<double>());
        EXPECT_NEAR(rmse, all["rmse"].get<double>(), 1e-6 * std::max(1.0, rmse)) << channel;
        EXPECT_GT(rmse, 0.0) << channel;
    }
}

// compare A.exr B.exr: every channel of A against B's, no device; files that differ in
// size or channels are refused (exit 1) naming both; the config form's flags are refused.
TEST_F(Cli, CompareTakesTwoExrFiles)
{
    Exr reference;
    reference.width = 4;
    reference.height = 2;
    reference.channels["sun.V"] = {1, 1, 1, 1, 0, 0, 0.5f, 0.5f};
    reference.channels["Y"] = reference.channels["sun.V"];
    Exr test = reference;
    test.channels["sun.V"][6] = 0.9f;  // one pixel of eight off by 0.4: RMSE sqrt(0.16 / 8)
    writeExr(dir / "a.exr", test);
    writeExr(dir / "b.exr", reference);
    CliResult r = run(fmt::format("compare '{0}/a.exr' '{0}/b.exr' --json", dir.string()));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const nlohmann::json doc = nlohmann::json::parse(r.out);
    EXPECT_EQ(doc["reference"], (dir / "b.exr").string());
    ASSERT_EQ(doc["channels"].size(), 2u);
    for (const nlohmann::json& c : doc["channels"]) {
        EXPECT_NEAR(c["visibility"]["all"]["rmse"].get<double>(), c["name"] == "sun.V" ? std::sqrt(0.16 / 8) : 0.0, 1e-6) << c.dump();
    }
    r = run(fmt::format("compare '{0}/b.exr' '{0}/b.exr'", dir.string()));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(has(r.out, "channel 'sun.V'")) << r.out;

    Exr small = reference;
    small.width = 2;
    for (auto& [name, values] : small.channels) values.resize(4);
    writeExr(dir / "small.exr", small);
    r = run(fmt::format("compare '{0}/a.exr' '{0}/small.exr'", dir.string()));
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_TRUE(has(r.err, "a.exr is 4x2 and") && has(r.err, "small.exr is 2x2")) << r.err;
    r = run(fmt::format("compare '{0}/a.exr' '{0}/b.exr' --width 8", dir.string()));
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_TRUE(has(r.err, "--width")) << r.err;
    r = run(fmt::format("compare '{0}/a.exr'", dir.string()));
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_TRUE(has(r.err, "compare A.exr B.exr")) << r.err;
}

// A spot light's figures count only the pixels it reaches (issue 19): outside its outer
// cone the techniques write V = 1 by contract while the reference traces rays, and the
// boxes' traced shadows there scored errors no image shows (RMSE 0.32, umbra 0.75 on this
// view before). Now the comparison is taken inside the cone: hard against the reference
// of a light without size differs at shadow edges only.
TEST_F(Cli, CompareCountsOnlyThePixelsASpotLightReaches)
{
    const fs::path cfg = dir / "spot.json";
    std::ofstream(cfg) << fmt::format(R"({{"include": {}, "lights": [{{"name": "lamp", "type": "spot",
        "position": [-2.0, 9.0, 1.0], "target": [0.0, 0.0, 0.0], "outer_cone_deg": 35.0, "inner_cone_deg": 30.0,
        "intensity": 900.0, "shadow": {{"technique": "hard", "resolution": 2048}}}}]}})",
                                      nlohmann::json(penumbra::test::sourceDir().string() + "/config/default.json").dump());
    // The real (Embree) reference in a child process: under AddressSanitizer the leak
    // check at exit runs while Embree's TBB worker threads wind down, and LeakSanitizer's
    // thread tracer crashes there about one run in six (SIGSEGV, exit 134). Address
    // errors are still checked; release builds ignore the variable.
    const CliResult r = run(fmt::format("compare '{}' --width 320 --height 180 --json -o '{}'", cfg.string(),
                                        (dir / "out").string()),
                            "ASAN_OPTIONS=detect_leaks=0:abort_on_error=1:strict_string_checks=1");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const nlohmann::json doc = nlohmann::json::parse(r.out);
    const nlohmann::json& v = doc["lights"][0]["visibility"];
    const int compared = v["all"]["pixels"], geometry = doc["color"]["all"]["pixels"];
    EXPECT_GT(compared, 2000) << "the cone covers part of the view";
    EXPECT_LT(compared, geometry / 2) << "pixels outside the cone are not compared";
    EXPECT_GT(v["regions"]["umbra"]["pixels"].get<int>(), 500) << "shadows inside the cone";
    EXPECT_LE(v["regions"]["umbra"]["rmse"].get<double>(), 0.05);
    EXPECT_LE(v["all"]["rmse"].get<double>(), 0.1);
    // Not compared: grey in the difference image, as the sky.
    EXPECT_EQ(readImage(dir / "out" / "lamp.diff.png").at(0, 179), (std::vector<int>{128, 128, 128, 255}));
}

TEST_F(Cli, CompareRefusesBadInputBeforeRenderingOrWriting)
{
    const fs::path cfg = dir / "cfg.json";
    std::ofstream(cfg) << compareConfig("0.25");
    const fs::path out = dir / "out";
    const auto refused = [&](const std::string& flags, const std::string& message) {
        const CliResult r = run(fmt::format("compare '{}' {} -o '{}'", cfg.string(), flags, out.string()), pluginPath());
        EXPECT_EQ(r.exitCode, 1) << flags;
        EXPECT_TRUE(has(r.err, message)) << flags << "\n" << r.err;
        EXPECT_FALSE(has(r.err, "render:")) << "nothing rendered: " << r.err;
        EXPECT_FALSE(fs::exists(out)) << flags;
    };
    refused("--reference nosuch", "--reference nosuch: plugin 'nosuch': no file penumbra-nosuch.so on the plugin search path");
    refused("--reference testgood --reference-set fil=0.5",
            "--reference-set fil: plugin 'testgood' has no parameter 'fil'; did you mean 'fill'?");
    refused("--reference testgood --reference-set fill=3", "--reference-set fill: must be a number in [0, 1]");
    refused("--reference testgood --reference-set fill", "--reference-set 'fill': expected parameter=value");
    refused("--reference testgood --reference-set hard.fill=1",
            "--reference-set 'hard.fill=1': 'hard' is not the reference technique 'testgood'");
    refused("--reference testgood --set testgood.kernel=99", "--set testgood.kernel: must be an integer in [1, 15]");
    refused("--reference testgood --set other.size=1", "--set other.size: no light of ");
    refused("--reference testgood --diff-scale 0", "--diff-scale must be in (0, 1], got 0");

    expectBadOutputFoldersRefused(fmt::format("compare '{}' {}", cfg.string(), kTestGoodReference), pluginPath());

    const CliResult r = run(fmt::format("compare '{}/nope.json' {}", dir.string(), kTestGoodReference), pluginPath());
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_TRUE(has(r.err, "nope.json: config file not found")) << r.err;
    EXPECT_NE(run("compare").exitCode, 0) << "the config is required";
}
