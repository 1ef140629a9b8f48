// `penumbra render`: images and frame patterns, --timings and --stats, debug images, the
// visibility EXR, and a render that fails leaving no file and the existing one untouched.
#include "CliTest.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

using namespace penumbra::test;
namespace fs = std::filesystem;

namespace {

// One row of `render --timings`: a pass, its GPU ms, and its multiple of the floor.
struct TimingRow {
    double gpuMs = 0.0;
    double multiple = 0.0;
    std::string against;
};

// The rows of the frame's table ("name gpu cpu multiple against...") and of the floor's
// ("name gpu"), by name.
std::map<std::string, TimingRow> timingRows(const std::string& out)
{
    std::map<std::string, TimingRow> rows;
    std::istringstream lines(out);
    for (std::string line; std::getline(lines, line);) {
        std::istringstream words(line);
        std::string name;
        TimingRow row;
        double cpuMs = 0.0;
        if (!(words >> name >> row.gpuMs)) continue;
        if (words >> cpuMs >> row.multiple) std::getline(words >> std::ws, row.against);
        rows[name] = row;
    }
    return rows;
}

} // namespace

TEST_F(Cli, RendersTheDefaultSceneToPng)
{
    const fs::path png = dir / "out.png";
    const CliResult r = run(fmt::format("render {} -o '{}' --width 160 --height 90 --validation", config("default.json"), png.string()));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const std::string bytes = readFile(png);
    ASSERT_GT(bytes.size(), 8u);
    EXPECT_EQ(bytes.substr(1, 3), "PNG");
}

TEST_F(Cli, TimingsListEveryPass)
{
    const fs::path png = dir / "out.png";
    const CliResult r = run(fmt::format("render {} -o '{}' --width 160 --height 90 --frames 3 --timings", config("default.json"),
                                  png.string()));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    for (const char* pass : {"gbuffer", "light0.hard.shadow_map", "shading", "median of 3 frame(s)"}) {
        EXPECT_NE(r.out.find(pass), std::string::npos) << pass << "\n" << r.out;
    }
    // Nothing but shading reads V: shading evaluates hard's visibility function, and the
    // visibility pass is not there. Asked for V, the pass writes it.
    EXPECT_EQ(r.out.find("light0.hard.visibility"), std::string::npos) << r.out;
    const fs::path exr = dir / "v.exr";
    const CliResult withV = run(fmt::format("render {} -o '{}' --width 160 --height 90 --frames 3 --timings --visibility-exr '{}'",
                                            config("default.json"), png.string(), exr.string()));
    ASSERT_EQ(withV.exitCode, 0) << withV.err;
    EXPECT_NE(withV.out.find("light0.hard.visibility"), std::string::npos) << withV.out;
}

TEST_F(Cli, TimingsGiveEveryPassAsAMultipleOfTheFloor)
{
    const fs::path png = dir / "out.png";
    // With V asked for, so that the technique's visibility pass is timed too.
    const CliResult r = run(fmt::format("render {} -o '{}' --width 160 --height 90 --frames 3 --warmup 1 --timings "
                                        "--keep-unchanged false --visibility-exr '{}'",
                                        config("default.json"), png.string(), (dir / "v.exr").string()));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    // The rule heads the table.
    EXPECT_TRUE(has(r.out, "x floor: a camera pass (writes an image of the frame's size) over the floor's forward draw, "
                           "any other pass over the floor's shadow-map draw of its light"))
        << r.out;
    const std::map<std::string, TimingRow> rows = timingRows(r.out);
    for (const char* name : {"gbuffer", "light0.hard.shadow_map", "light0.hard.visibility", "shading",
                             "floor.shadowed.light0.shadow_map", "floor.shadowed.forward", "floor.unshadowed.forward"}) {
        ASSERT_TRUE(rows.count(name)) << name << "\n" << r.out;
        EXPECT_GT(rows.at(name).gpuMs, 0.0) << name;
    }
    const double forward = rows.at("floor.shadowed.forward").gpuMs, map = rows.at("floor.shadowed.light0.shadow_map").gpuMs;
    // Camera passes against the forward draw, the light's map against the floor's map;
    // the multiples are the printed times' ratios up to their rounding.
    const auto expectMultiple = [&](const char* name, const char* against, double floorMs) {
        const TimingRow& row = rows.at(name);
        EXPECT_EQ(row.against, against) << name;
        EXPECT_NEAR(row.multiple, row.gpuMs / floorMs, 0.006 + 0.002 * row.gpuMs / floorMs) << name << "\n" << r.out;
    };
    expectMultiple("gbuffer", "forward", forward);
    expectMultiple("light0.hard.visibility", "forward", forward);
    expectMultiple("shading", "forward", forward);
    expectMultiple("light0.hard.shadow_map", "shadow map", map);
    // The frame's sum against the shadowed floor frame (the light is shadowed).
    double sum = 0.0, multiple = 0.0, floorFrame = 0.0;
    std::istringstream lines(r.out);
    for (std::string line; std::getline(lines, line);) {
        if (has(line, "sum of passes (GPU)")) {
            ASSERT_EQ(std::sscanf(line.c_str(), " sum of passes (GPU) %lf %lf", &sum, &multiple), 2) << line;
            EXPECT_TRUE(has(line, "shadowed floor frame")) << line;
        }
        if (line.rfind("  shadowed floor frame", 0) == 0) {
            ASSERT_EQ(std::sscanf(line.c_str(), " shadowed floor frame %lf", &floorFrame), 1) << line;
        }
    }
    ASSERT_GT(sum, 0.0) << r.out;
    ASSERT_GT(floorFrame, 0.0) << r.out;
    EXPECT_NEAR(multiple, sum / floorFrame, 0.006 + 0.002 * sum / floorFrame) << r.out;
}

// A still frame keeps every pass (keep_unchanged): --timings says so, and the image is
// the one of every pass run; --keep-unchanged false runs them all again.
TEST_F(Cli, TimingsShowPassesAStillFrameKept)
{
    const fs::path kept = dir / "kept.png", ran = dir / "ran.png";
    const CliResult r = run(fmt::format("render {} -o '{}' --width 96 --height 54 --frames 3 --warmup 1 --timings",
                                        config("default.json"), kept.string()));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const std::map<std::string, TimingRow> rows = timingRows(r.out);
    for (const char* name : {"gbuffer", "light0.hard.shadow_map", "shading"}) {
        ASSERT_TRUE(rows.count(name)) << name << "\n" << r.out;
        EXPECT_EQ(rows.at(name).gpuMs, 0.0) << name;
        EXPECT_TRUE(has(rows.at(name).against, "kept in 3 of 3 frames")) << name << "\n" << r.out;
    }
    const CliResult all = run(fmt::format("render {} -o '{}' --width 96 --height 54 --frames 3 --warmup 1 --timings "
                                          "--keep-unchanged false",
                                          config("default.json"), ran.string()));
    ASSERT_EQ(all.exitCode, 0) << all.err;
    EXPECT_FALSE(has(all.out, "kept in")) << all.out;
    EXPECT_GT(timingRows(all.out).at("light0.hard.shadow_map").gpuMs, 0.0) << all.out;
    EXPECT_EQ(readFile(kept), readFile(ran)) << "the kept frame is not the frame of every pass";
}

// Warm-up frames run whatever the frame count; without --warmup, one when timing.
TEST_F(Cli, WarmupAppliesAtOneFrameToo)
{
    const fs::path png = dir / "out.png";
    CliResult r = run(fmt::format("render {} -o '{}' --width 64 --height 36 --frames 1 --warmup 3 --timings",
                                  config("default.json"), png.string()));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(has(r.out, "timings: median of 1 frame(s) after 3 warm-up")) << r.out;
    EXPECT_TRUE(has(r.err, "3 warm-up frame(s), 1 measured")) << r.err;
    r = run(fmt::format("render {} -o '{}' --width 64 --height 36 --frames 1 --timings", config("default.json"), png.string()));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(has(r.out, "timings: median of 1 frame(s) after 1 warm-up")) << r.out;
    r = run(fmt::format("render {} -o '{}' --width 64 --height 36", config("default.json"), png.string()));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(has(r.err, "0 warm-up frame(s), 1 measured")) << r.err;
}

TEST_F(Cli, StatsReportWhatCullingDrew)
{
    const fs::path png = dir / "out.png";
    const CliResult none = run(fmt::format("render {} -o '{}' --width 160 --height 90 --frames 2 --stats --culling none "
                                           "--keep-unchanged false",
                                           config("default.json"), png.string()));
    ASSERT_EQ(none.exitCode, 0) << none.err;
    EXPECT_NE(none.out.find("culling none"), std::string::npos) << none.out;
    EXPECT_NE(none.out.find("triangles drawn in caster passes       9326"), std::string::npos) << none.out;
    const CliResult mask = run(fmt::format("render {} -o '{}' --width 160 --height 90 --frames 2 --stats --culling "
                                           "receiver-mask --validation",
                                           config("default.json"), png.string()));
    ASSERT_EQ(mask.exitCode, 0) << mask.err;
    for (const char* line : {"culling receiver-mask", "occlusion queries issued", "BVH nodes visited", "receiver masks ms"})
        EXPECT_NE(mask.out.find(line), std::string::npos) << line << "\n" << mask.out;
    const CliResult bad = run(fmt::format("render {} -o '{}' --culling occlusion", config("default.json"), png.string()));
    EXPECT_NE(bad.exitCode, 0);
    EXPECT_NE(bad.err.find("--culling"), std::string::npos) << bad.err;
}

// A light that cannot matter (frame/LightInfluence.h) is culled, and `render --stats`,
// `--timings` and `graph` say which and why.
TEST_F(Cli, CulledLightsAreReportedWithTheReason)
{
    nlohmann::json doc = nlohmann::json::parse(readFile(penumbra::test::sourceDir() / "config" / "default.json"));
    nlohmann::json up = doc["lights"][0];
    up["name"] = "up";
    up["position"] = {0.0, 12.0, 0.0};
    up["target"] = {0.5, 20.0, 0.0};
    doc["lights"].push_back(up);
    const fs::path file = dir / "two.json";
    std::ofstream(file) << doc.dump(1);
    const fs::path png = dir / "out.png";
    const std::string summary = "lights (last frame): 1 shadowed, 0 unshadowed, 1 culled (of 2)";
    const std::string line = "light 1 ('up'): culled in 2 of 2 frame(s): its cone (42 degrees from its axis) meets no "
                             "visible receiver";
    for (const char* flag : {"--stats", "--timings"}) {
        const CliResult r = run(fmt::format("render '{}' -o '{}' --width 64 --height 36 --frames 2 {}", file.string(),
                                            png.string(), flag));
        ASSERT_EQ(r.exitCode, 0) << r.err;
        EXPECT_TRUE(has(r.out, summary)) << flag << "\n" << r.out;
        EXPECT_TRUE(has(r.out, line)) << flag << "\n" << r.out;
    }
    const CliResult graph = run(fmt::format("graph '{}' --width 64 --height 36", file.string()));
    ASSERT_EQ(graph.exitCode, 0) << graph.err;
    EXPECT_TRUE(has(graph.out, "light 1 ('up'): culled in 1 of 1 frame(s): its cone")) << graph.out;
    EXPECT_FALSE(has(graph.out, "light1.hard.")) << "a culled light has no passes\n" << graph.out;
}

// The SPIR-V cache (gpu/ShaderCache.h): a second render of the same config compiles no
// shader, it reads every one the first compiled from the disk.
TEST_F(Cli, SecondRenderCompilesNoShader)
{
    const std::string cache = fmt::format("XDG_CACHE_HOME='{}'", (dir / "cache").string());
    const std::string args = fmt::format("render {} -o '{}' --width 32 --height 18 --stats", config("default.json"),
                                         (dir / "out.png").string());
    const CliResult first = run(args, cache);
    ASSERT_EQ(first.exitCode, 0) << first.err;
    EXPECT_TRUE(has(first.out, fmt::format("  {:<39}{}\n", "found on disk", 0))) << first.out;
    EXPECT_FALSE(has(first.out, fmt::format("  {:<39}{}\n", "compiled", 0))) << first.out;
    EXPECT_TRUE(has(first.out, "shaders (cache " + (dir / "cache" / "penumbra" / "spirv").string())) << first.out;
    const CliResult second = run(args, cache);
    ASSERT_EQ(second.exitCode, 0) << second.err;
    EXPECT_TRUE(has(second.out, fmt::format("  {:<39}{}\n", "compiled", 0))) << second.out;
    EXPECT_FALSE(has(second.out, fmt::format("  {:<39}{}\n", "found on disk", 0))) << second.out;
    EXPECT_TRUE(has(second.out, fmt::format("  {:<39}{}\n", "damaged cache files ignored", 0))) << second.out;
    EXPECT_FALSE(has(second.err, "shader cache")) << second.err;
}

TEST_F(Cli, MissingConfig)
{
    const CliResult r = run(fmt::format("render '{}/nope.json' -o '{}/out.png'", dir.string(), dir.string()));
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("nope.json: config file not found"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir / "out.png"));
}

TEST_F(Cli, MalformedConfig)
{
    const CliResult r = run(fmt::format("render {} -o '{}/out.png'", data("configs/malformed.json"), dir.string()));
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("malformed.json: malformed JSON"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("line 4"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir / "out.png"));
}

TEST_F(Cli, InvalidConfigNamesJsonPath)
{
    const fs::path cfg = dir / "bad.json";
    std::ofstream(cfg) << R"({"camera": {"position": [0, 5, 10], "target": [0, 0, 0]},
        "lights": [{"position": [0, 10, 0], "target": [0, 0, 0], "intensity": -3}]})";
    const CliResult r = run(fmt::format("render '{}' -o '{}/out.png'", cfg.string(), dir.string()));
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("bad.json: /lights/0/intensity: must be in [0, "), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir / "out.png"));
}

TEST_F(Cli, MissingOutputFolder)
{
    const CliResult r = run(fmt::format("render {} -o '{}/no/such/dir/out.png'", config("default.json"), dir.string()));
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("does not exist"), std::string::npos) << r.err;
}

TEST_F(Cli, UnwritableOutputLeavesNoFile)
{
    // /proc refuses new files even for root; the error must name the path.
    const CliResult r = run(fmt::format("render {} -o /proc/penumbra-out.png --width 32 --height 32", config("default.json")));
    EXPECT_NE(r.exitCode, 0);
    EXPECT_NE(r.err.find("/proc/penumbra-out.png"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists("/proc/penumbra-out.png"));
}

TEST_F(Cli, FailedRenderKeepsTheExistingOutput)
{
    const fs::path png = dir / "out.png";
    std::ofstream(png) << "keep me";
    const CliResult r = run(fmt::format("render {} -o '{}' --device no-such-gpu", config("default.json"), png.string()));
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_EQ(readFile(png), "keep me");
    // No temporary files left beside it either.
    size_t files = 0;
    for (const auto& e : fs::directory_iterator(dir)) files += e.path().extension() != ".txt";
    EXPECT_EQ(files, 1u);
}

TEST_F(Cli, AnimatedRunWritesEveryFrame)
{
    const CliResult r = run(fmt::format("render {} -o '{}/f{{frame:02}}.png' --width 48 --height 32 --frames 3 --validation",
                                        config("animated.json"), dir.string()));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    for (const char* name : {"f00.png", "f01.png", "f02.png"}) EXPECT_TRUE(fs::exists(dir / name)) << name;
    EXPECT_FALSE(fs::exists(dir / "f03.png"));
}

TEST_F(Cli, BadFramePatternIsAnError)
{
    const CliResult r = run(fmt::format("render {} -o '{}/f{{frame:q}}.png' --width 16 --height 16", config("default.json"),
                                        dir.string()));
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("output pattern"), std::string::npos) << r.err;
}

TEST_F(Cli, RendersAGltfSceneFromAConfig)
{
    const fs::path png = dir / "gltf.png";
    const CliResult r = run(fmt::format("render {} -o '{}' --validation", data("configs/gltf_scene.json"), png.string()));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(fs::exists(png));
    const CliResult v = run(fmt::format("validate {}", data("configs/gltf_scene.json")));
    ASSERT_EQ(v.exitCode, 0) << v.err;
    for (const char* text : {"scene: 1 part(s), 2 meshes, 4 instances, 6 triangles, 2 materials, 0 textures, bounds (",
                             "  part 0 'part0': ", "hierarchy.gltf, translation (0, 0, 0), rotation (0, 0, 0, 1), scale 1: 4 "
                                                   "instances, 6 triangles, bounds ("}) {
        EXPECT_NE(v.out.find(text), std::string::npos) << text << "\n" << v.out;
    }
}

TEST_F(Cli, RendersAGltfSceneWithItsOwnLights)
{
    const fs::path png = dir / "lights.png";
    const CliResult r = run(fmt::format("render {} -o '{}' --validation", data("configs/gltf_scene_lights.json"), png.string()));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.err.find("3 light(s)"), std::string::npos) << r.err;
}

TEST_F(Cli, TheOutputNameChoosesPngOrJpegAndOtherNamesAreRefused)
{
    const fs::path jpg = dir / "out.jpg";
    CliResult r = run(fmt::format("render {} -o '{}' --width 32 --height 18", config("default.json"), jpg.string()));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const std::string bytes = readFile(jpg);
    ASSERT_GT(bytes.size(), 3u);
    EXPECT_EQ(bytes.substr(0, 3), "\xFF\xD8\xFF");  // a JPEG, not PNG bytes under a .jpg name
    const Rgba8Image image = readImage(jpg);
    EXPECT_EQ(image.width, 32);
    EXPECT_EQ(image.height, 18);

    for (const char* name : {"out.bmp", "out", "f{frame:04}.tif"}) {
        SCOPED_TRACE(name);
        r = run(fmt::format("render {} -o '{}/{}' --device no-such-gpu", config("default.json"), dir.string(), name));
        EXPECT_EQ(r.exitCode, 1);
        EXPECT_TRUE(has(r.err, "an image is written as .png or .jpg (.jpeg)")) << r.err;
        EXPECT_FALSE(has(r.err, "no suitable device")) << r.err;
        EXPECT_FALSE(fs::exists(dir / name));
    }
}

// render --visibility-exr: the last frame's V of every light, next to the PNG; a path
// that cannot be written stops the run before rendering, naming it, and leaves no file.
TEST_F(Cli, RenderWritesEveryLightsVisibilityAsFloats)
{
    const fs::path exr = dir / "v.exr";
    CliResult r = run(fmt::format("render {} -o '{}' --width 96 --height 54 --visibility-exr '{}'", config("two-spots.json"),
                                  (dir / "out.png").string(), exr.string()));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const Exr v = readExr(exr);
    EXPECT_EQ(v.width, 96);
    EXPECT_EQ(v.height, 54);
    ASSERT_EQ(v.channels.size(), 3u);
    EXPECT_EQ(v.channels.at("Y"), v.channels.at("light0.V")) << "Y is the first light's V, for image viewers";
    for (const auto& [name, values] : v.channels) {
        EXPECT_TRUE(name == "Y" || name.substr(name.size() - 2) == ".V") << name;
        size_t shadowed = 0;
        for (const float x : values) {
            ASSERT_TRUE(x >= 0.0f && x <= 1.0f) << name << ": " << x;
            shadowed += x < 0.5f ? 1 : 0;
        }
        EXPECT_GT(shadowed, 20u) << name;
    }
    r = run(fmt::format("render {} -o '{}' --width 96 --height 54 --visibility-exr '{}/missing/v.exr'",
                        config("two-spots.json"), (dir / "again.png").string(), dir.string()));
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("missing/v.exr"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir / "again.png")) << "refused before rendering";
}

// A technique's own figures (plugin::Technique::figures: a deep shadow map's fragments,
// pool and depth complexity) in `render --stats`, `graph` and the bench's results and
// summary.
TEST_F(Cli, TechniqueFiguresAreReportedEverywhere)
{
    const fs::path cfg = dir / "cfg.json";
    std::ofstream(cfg) << R"({
        "scene": {"generator": "hair", "params": {"strands": 500}},
        "camera": {"position": [0.75, 0.6, 0.95], "target": [0, 0.42, 0], "near": 0.005},
        "lights": [{"type": "spot", "position": [0.9, 1.6, 0.5], "target": [0, 0.3, 0], "outer_cone_deg": 30,
                    "shadow": {"technique": "deep", "resolution": 128, "pool_mib": 1}}],
        "output": {"width": 48, "height": 36},
        "sweep": [{"path": "/lights/0/shadow/pcf_kernel", "labels": ["1", "3"], "values": [1, 3]}]})";
    const fs::path png = dir / "out.png";
    CliResult r = run(fmt::format("render '{}' -o '{}' --frames 2 --stats --validation", cfg.string(), png.string()));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    for (const char* line : {"light 0 (deep) figures (median per frame)", "fragments", "dropped_fragments ",
                             "pool_used_mib", "texels_with_1_fragments"})
        EXPECT_NE(r.out.find(line), std::string::npos) << line << "\n" << r.out;
    r = run(fmt::format("graph '{}'", cfg.string()));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("light 0 (deep) figures"), std::string::npos) << r.out;
    const fs::path out = dir / "bench";
    r = run(fmt::format("bench '{}' --reference-set samples=1 --reference-set cache=false --frames 1 --warmup 0 -o '{}' "
                        "--summary '{}'",
                        cfg.string(), out.string(), (dir / "summary.md").string()));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const nlohmann::json light = nlohmann::json::parse(readFile(out / "results.json"))["variants"][1]["lights"][0];
    std::map<std::string, double> figures;
    for (const nlohmann::json& f : light["figures"]) figures[f["name"]] = f["value"];
    EXPECT_GT(figures["fragments"], 0.0);
    EXPECT_EQ(figures["dropped_fragments"], 0.0);
    EXPECT_NE(readFile(dir / "summary.md").find("## Technique figures"), std::string::npos);
}

// --debug-image (issue 21, debug views): any image of the frame's graph, by name, written
// as the PNG; the frame's own images and every technique's intermediate ones.
TEST_F(Cli, DebugImageWritesAnyGraphImageByName)
{
    struct Case {
        const char* config;
        const char* image;
        const char* mapping;
        int channels;
        size_t colours;  // at least this many distinct colours in a sample of pixels
    };
    // A depth map, a moment map, a point light's cube atlas (pcss), the G-buffer's packed
    // normal (two channels), the colour image (four), a visibility image (a hard shadow's
    // is 0 or 1: two colours). The maps at 256² (--set), small enough to read back and
    // encode quickly under the sanitizers.
    const Case cases[] = {{"default.json", "light0.hard.shadow_map", "linear", 1, 3},
                          {"vsm.json", "light0.vsm.moments", "false-color", 4, 3},
                          {"pcss.json", "light0.pcss.shadow_map", "log", 1, 3},
                          {"default.json", "gbuffer.normal", "linear", 2, 3},
                          {"default.json", "color", "linear", 4, 3},
                          {"default.json", "light0.visibility", "linear", 1, 2}};
    for (const Case& c : cases) {
        SCOPED_TRACE(fmt::format("{} {}", c.config, c.image));
        const fs::path png = dir / "debug.png";
        fs::remove(png);
        // "light0.<technique>.<map>": that technique's maps at 256².
        const std::string name = c.image;
        const size_t dot = name.find('.'), next = name.find('.', dot + 1);
        const std::string size = name.rfind("light", 0) == 0 && next != std::string::npos
                                     ? fmt::format("--set {}.resolution=256", name.substr(dot + 1, next - dot - 1))
                                     : "";
        const CliResult r = run(fmt::format("render {} -o '{}' --width 96 --height 64 --validation --debug-image {} "
                                            "--debug-map {} {}",
                                            config(c.config), png.string(), c.image, c.mapping, size));
        if (r.exitCode == 1 && has(r.err, "the frame has no such image")) {
            ADD_FAILURE() << r.err;  // the names below say what the frame has
            continue;
        }
        ASSERT_EQ(r.exitCode, 0) << r.err;
        EXPECT_TRUE(has(r.err, fmt::format("debug image '{}': ", c.image))) << r.err;
        EXPECT_TRUE(has(r.err, fmt::format("{} channel(s)", c.channels))) << r.err;
        const Rgba8Image image = readImage(png);
        ASSERT_GT(image.width, 0);
        std::set<std::vector<int>> colours;
        for (int y = 0; y < image.height; y += 7)
            for (int x = 0; x < image.width; x += 7) colours.insert(image.at(x, y));
        EXPECT_GE(colours.size(), c.colours) << "a map with content maps to several colours";
    }
}

TEST_F(Cli, DebugImageRefusesUnknownNamesAndBadMappingsNamingThem)
{
    const fs::path png = dir / "x.png";
    CliResult r = run(fmt::format("render {} -o '{}' --width 64 --height 48 --debug-image nope", config("default.json"),
                                  png.string()));
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_TRUE(has(r.err, "debug image 'nope': the frame has no such image; its images: ")) << r.err;
    EXPECT_TRUE(has(r.err, "light0.hard.shadow_map")) << r.err;
    EXPECT_TRUE(has(r.err, "gbuffer.normal")) << r.err;
    EXPECT_FALSE(fs::exists(png));
    for (const char* flags : {"--debug-map sqrt", "--debug-range 1", "--debug-range 2,1", "--debug-range 0,inf",
                              "--debug-range a,b"}) {
        SCOPED_TRACE(flags);
        r = run(fmt::format("render {} -o '{}' --debug-image color {}", config("default.json"), png.string(), flags));
        EXPECT_EQ(r.exitCode, 1) << r.err;
        EXPECT_TRUE(has(r.err, "--debug-range '") || has(r.err, "debug image mapping 'sqrt'")) << r.err;
        EXPECT_FALSE(has(r.err, "scene:")) << "refused before rendering: " << r.err;
        EXPECT_FALSE(fs::exists(png));
    }
    // An explicit range maps its ends to black and white.
    r = run(fmt::format("render {} -o '{}' --width 64 --height 48 --debug-image light0.visibility --debug-range 0,1",
                        config("default.json"), png.string()));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(has(r.err, "shown linear over [0, 1]")) << r.err;
}
