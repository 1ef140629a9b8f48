// Config files as an attacker or a broken generator writes them (issue 20): every one is
// a ConfigError (the CLI's exit 1) naming the file and the JSON path, never an internal
// error, a crash or a hang. Numbers beyond a double's range, nesting beyond
// config::kMaxConfigNesting (checked while parsing, before anything recurses), file names
// the file system refuses, sweep paths with array indices beyond 64 bits or a million
// levels; FIFOs, devices and files beyond config::kMaxConfigBytes; long names and paths
// are shortened in messages. Work bounded by the input (issue 43): fps and key times
// within Animation.h's limits and every track evaluation finite; includes limited to
// config::kMaxConfigFiles files and kMaxConfigBytes together; parsing linear in the
// number of objects; sweep variants made one at a time up to kMaxSweepCombinations.
#include "ScratchFolder.h"
#include "TestConfigs.h"

#include "engine/src/config/ConfigJson.h"
#include "penumbra/config/Config.h"
#include "penumbra/config/Document.h"
#include "penumbra/config/Sweep.h"
#include "penumbra/core/Error.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/stat.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>

using namespace penumbra;
namespace fs = std::filesystem;

namespace {

class HostileConfig : public test::ScratchFolderTest {
protected:
    fs::path write(const std::string& name, const std::string& text) const
    {
        const fs::path file = dir / name;
        std::ofstream(file, std::ios::binary) << text;
        return file;
    }

    // The ConfigError of loading and expanding `file` (every variant of its sweep).
    static std::string errorLoading(const fs::path& file)
    {
        try {
            test::everyVariant(config::loadDocument(file));
        } catch (const ConfigError& e) {
            return e.what();
        }
        ADD_FAILURE() << file << " was accepted";
        return {};
    }

    static std::string minimalWith(const std::string& lightsIntensity)
    {
        return R"({"camera": {"position": [0, 5, 10], "target": [0, 0, 0]},
                   "lights": [{"type": "spot", "position": [0, 10, 0], "target": [0, 0, 0], "intensity": )" +
               lightsIntensity + "}]}";
    }

};

} // namespace

TEST_F(HostileConfig, NumbersBeyondADoubleNameTheirPath)
{
    for (const char* number : {"1e309", "-1e999", "1e400000", "123456789e400"}) {
        SCOPED_TRACE(number);
        const std::string what = errorLoading(write("big.json", minimalWith(number)));
        EXPECT_NE(what.find("big.json: /lights/0/intensity: "), std::string::npos) << what;
        EXPECT_NE(what.find(number), std::string::npos) << what;
        EXPECT_NE(what.find("double's range"), std::string::npos) << what;
    }
    // In an array, at the top level, in an included file.
    EXPECT_NE(errorLoading(write("array.json", R"({"camera": {"position": [0, 1e309, 10]}})")).find("/camera/position/1: "),
              std::string::npos);
    EXPECT_NE(errorLoading(write("top.json", R"({"frames": 1e309})")).find("top.json: /frames: "), std::string::npos);
    write("base.json", R"({"output": {"width": 2e999}})");
    const std::string included = errorLoading(write("inc.json", R"({"include": "base.json"})"));
    EXPECT_NE(included.find("base.json: /output/width: "), std::string::npos) << included;
}

TEST_F(HostileConfig, NestingIsLimitedWhileParsing)
{
    // kMaxConfigNesting levels parse (the config is then refused for what it says, not
    // for its depth); one more, of objects or arrays, is refused naming the limit and the
    // path it reached.
    const auto nested = [](int levels, bool arrays) { return "{\"x\":" + test::nestedJson(levels - 1, arrays) + "}"; };
    for (bool arrays : {false, true}) {
        SCOPED_TRACE(arrays ? "arrays" : "objects");
        const std::string ok = errorLoading(write("ok.json", nested(config::kMaxConfigNesting, arrays)));
        EXPECT_EQ(ok.find("nested deeper"), std::string::npos) << ok;
        const std::string deep = errorLoading(write("deep.json", nested(config::kMaxConfigNesting + 1, arrays)));
        EXPECT_NE(deep.find("deep.json: /x/"), std::string::npos) << deep.substr(0, 200);
        EXPECT_NE(deep.find("nested deeper than 64 levels"), std::string::npos) << deep.substr(0, 400);
        // 40,000 levels (the depth that overflowed the stack): the same error.
        const std::string hostile = errorLoading(write("hostile.json", nested(40000, arrays)));
        EXPECT_NE(hostile.find("nested deeper than 64 levels"), std::string::npos) << hostile.substr(0, 400);
    }
}

TEST_F(HostileConfig, FileNamesTheFileSystemRefusesAreNamedShortened)
{
    const std::string longName(5000, 'n');
    // As an include, alone and in a list.
    for (const std::string& include : {"\"" + longName + ".json\"", "[\"" + longName + ".json\"]"}) {
        const std::string what = errorLoading(write("inc.json", "{\"include\": " + include + "}"));
        EXPECT_NE(what.find("inc.json: /include"), std::string::npos) << what;
        EXPECT_NE(what.find("too long"), std::string::npos) << what;
        EXPECT_NE(what.find("characters)"), std::string::npos) << what;
        EXPECT_LT(what.size(), 600u) << "the name is shortened";
    }
    // As the config file itself.
    const std::string what = errorLoading(dir / (longName + ".json"));
    EXPECT_NE(what.find("too long"), std::string::npos) << what;
    EXPECT_LT(what.size(), 600u);
}

TEST_F(HostileConfig, OnlyRegularFilesOfBoundedSizeAreRead)
{
    // A FIFO would block the read forever, a device never end it: refused by type, as the
    // config itself and as an include, before any read.
    const fs::path fifo = dir / "pipe.json";
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    std::string what = errorLoading(fifo);
    EXPECT_NE(what.find("pipe.json: is a FIFO (named pipe), expected a JSON config file"), std::string::npos) << what;
    what = errorLoading(write("inc.json", R"({"include": "pipe.json"})"));
    EXPECT_NE(what.find("a FIFO"), std::string::npos) << what;
    for (const char* device : {"/dev/zero", "/dev/null"}) {
        what = errorLoading(write("dev.json", fmt::format(R"({{"include": "{}"}})", device)));
        EXPECT_NE(what.find(fmt::format("{}: is a character device, expected a JSON config file", device)), std::string::npos)
            << what;
    }
    what = errorLoading(dir);
    EXPECT_NE(what.find(fmt::format("{}: is a directory, expected a JSON config file", dir.filename().string())),
              std::string::npos)
        << what;
    // /proc files report 0 bytes: /proc/self/mem cannot be read from its start (an internal
    // error, exit 2, before), /proc/self/status is read to its end and parsed.
    what = errorLoading(write("mem.json", R"({"include": "/proc/self/mem"})"));
    EXPECT_NE(what.find("mem.json: /include: "), std::string::npos) << what;
    EXPECT_NE(what.find("/proc/self/mem: cannot be read: Input/output error"), std::string::npos) << what;
    what = errorLoading(write("status.json", R"({"include": "/proc/self/status"})"));
    EXPECT_NE(what.find("/proc/self/status: malformed JSON"), std::string::npos) << what;
    // One byte beyond kMaxConfigBytes (a sparse file: nothing is written) is refused by
    // its size; a file of exactly the limit is read (and refused as JSON, not for size).
    const fs::path big = write("big.json", "");
    fs::resize_file(big, config::kMaxConfigBytes + 1);
    what = errorLoading(big);
    EXPECT_NE(what.find(fmt::format("big.json: is {} bytes, more than the 64 MiB a JSON config file may hold",
                                    config::kMaxConfigBytes + 1)),
              std::string::npos)
        << what;
    fs::resize_file(big, config::kMaxConfigBytes);
    what = errorLoading(big);
    EXPECT_EQ(what.find("64 MiB"), std::string::npos) << what;
    EXPECT_NE(what.find("malformed JSON"), std::string::npos) << what;
}

TEST_F(HostileConfig, SweepPathsBeyondTheConfigAreRefused)
{
    const auto sweep = [&](const std::string& path) {
        return nlohmann::json{{"camera", {{"position", {0, 5, 10}}, {"target", {0, 0, 0}}}},
                              {"lights", {{{"type", "spot"}, {"position", {0, 10, 0}}, {"target", {0, 0, 0}}}}},
                              {"sweep", {{{"path", path}, {"values", {1, 2}}}}}}
            .dump();
    };
    // Array indices beyond 64 bits, and beyond the array.
    for (const char* index : {"99999999999999999999999", "18446744073709551616", "4294967296", "1"}) {
        SCOPED_TRACE(index);
        const std::string what = errorLoading(write("s.json", sweep(std::string("/lights/") + index + "/intensity")));
        EXPECT_NE(what.find("s.json: /sweep/0/path: "), std::string::npos) << what;
    }
    // More levels than a config nests: refused before the pointer is built (a million
    // levels took minutes), the message shortened.
    for (int levels : {config::kMaxConfigNesting + 1, 1000000}) {
        std::string path;
        for (int i = 0; i < levels; ++i) path += "/a";
        const std::string what = errorLoading(write("s.json", sweep(path)));
        EXPECT_NE(what.find("/sweep/0/path: a path of " + std::to_string(levels) + " levels"), std::string::npos)
            << what.substr(0, 300);
        EXPECT_LT(what.size(), 400u);
    }
    // One key of two million characters: named shortened.
    const std::string what = errorLoading(write("s.json", sweep("/" + std::string(2000000, 'k'))));
    EXPECT_NE(what.find("(2000001 characters)"), std::string::npos) << what.substr(0, 300);
    EXPECT_LT(what.size(), 1000u);
}

namespace {

// The default config with `animation` (JSON text) as its animation.
std::string animatedWith(const std::string& animation)
{
    nlohmann::json doc = nlohmann::json::parse(R"({"camera": {"position": [0, 5, 10], "target": [0, 0, 0]},
        "lights": [{"type": "spot", "position": [0, 10, 0], "target": [0, 0, 0]}]})");
    doc["animation"] = nlohmann::json::parse(animation);
    return doc.dump();
}

} // namespace

TEST_F(HostileConfig, FpsOutsideItsRangeIsRefusedNamingItsPath)
{
    // 1e-46 was 0 as a float, and frame / fps NaN: the track evaluation read past its keys.
    for (const char* interpolation : {"step", "linear", "smooth"}) {
        for (const char* fps : {"1e-46", "0", "-1", "1e-4", "1e308", "20000", "\"NaN\"", "\"inf\""}) {
            SCOPED_TRACE(fmt::format("{} {}", interpolation, fps));
            const std::string what = errorLoading(write("fps.json", animatedWith(fmt::format(
                R"({{"fps": {}, "tracks": [{{"target": "/camera/fov_y_deg", "interpolation": "{}",
                     "keys": [{{"t": 0, "value": 40}}, {{"t": 1, "value": 50}}, {{"t": 2, "value": 45}}]}}]}})",
                fps, interpolation))));
            EXPECT_NE(what.find("fps.json: /animation/fps: must be"), std::string::npos) << what;
        }
    }
}

TEST_F(HostileConfig, KeyTimesMustBeFiniteIncreasingAndWithinTheFrameLimit)
{
    const auto keys = [](const std::string& t0, const std::string& t1, const std::string& fps = "30") {
        return animatedWith(fmt::format(R"({{"fps": {}, "tracks": [{{"target": "/camera/fov_y_deg", "interpolation":
            "smooth", "keys": [{{"t": {}, "value": 40}}, {{"t": {}, "value": 50}}]}}]}})",
                                        fps, t0, t1));
    };
    const struct {
        std::string t0, t1, fps, expected;
    } cases[] = {
        {"0", "1e308", "30", "keys.json: /animation/tracks/0/keys/1/t: must be in [0, 1000000000]"},
        {"-1", "1", "30", "keys.json: /animation/tracks/0/keys/0/t: must be in [0, 1000000000]"},
        {"\"NaN\"", "1", "30", "keys.json: /animation/tracks/0/keys/0/t: must be a number"},
        {"2", "1", "30", "keys.json: /animation/tracks/0/keys/1/t: key times must increase strictly"},
        // Equal once they are floats.
        {"100000000", "100000001", "0.001", "keys.json: /animation/tracks/0/keys/1/t: key times must increase strictly"},
        // The last key beyond kMaxFrames frames.
        {"0", "1000000000", "30", "keys.json: /animation/tracks/0/keys/1/t: "},
        {"0", "1000000000", "30", " s at 30 fps is frame 30000000000; an animation ends within 1000000 frames"},
        {"0", "40000", "30", "40000 s at 30 fps is frame 1200000"},
    };
    for (const auto& c : cases) {
        SCOPED_TRACE(c.t0 + " " + c.t1 + " at " + c.fps);
        const std::string what = errorLoading(write("keys.json", keys(c.t0, c.t1, c.fps)));
        EXPECT_NE(what.find(c.expected), std::string::npos) << what;
    }
    // The slowest frame rate with a key a billion seconds on, just within kMaxFrames.
    const config::RenderConfig slow = config::loadConfig(write("slow.json", keys("0", "999000000", "0.001")));
    EXPECT_FLOAT_EQ(slow.animation.fps, 0.001f);
}

TEST(TrackEvaluation, IsFiniteAtEveryTimeForEveryInterpolation)
{
    // Values at a float's range: their differences are beyond it, and a huge key span next
    // to a tiny one.
    config::AnimationTrack track;
    track.target = "/camera/position";
    const float big = 3.0e38f;
    track.keys = {{0.0f, {-big, big, 0.0f}}, {1e-6f, {big, -big, 1.0f}}, {1e9f, {-big, big, 2.0f}}, {1e9f + 128.0f, {big, 0.0f, 3.0f}}};
    const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
    for (config::Interpolation interpolation :
         {config::Interpolation::Step, config::Interpolation::Linear, config::Interpolation::Smooth}) {
        track.interpolation = interpolation;
        for (float t : {nan, -inf, -1.0f, 0.0f, 5e-7f, 1e-6f, 0.5f, 5e8f, 1e9f + 64.0f, 2e9f, inf}) {
            const std::vector<float> v = config::evaluate(track, t);
            ASSERT_EQ(v.size(), 3u);
            for (float x : v) EXPECT_TRUE(std::isfinite(x)) << "t " << t << ": " << x;
        }
        // Before the first key (and at NaN) the first value, after the last the last.
        EXPECT_EQ(config::evaluate(track, nan), track.keys.front().value);
        EXPECT_EQ(config::evaluate(track, inf), track.keys.back().value);
    }
}

TEST_F(HostileConfig, AnAnimationWithoutTracksIsTheFrameRateOfTheScenesGltfAnimation)
{
    // Nothing to animate: an error naming /animation.
    for (const char* animation : {R"({"fps": 24})", R"({"fps": 24, "tracks": []})"}) {
        SCOPED_TRACE(animation);
        const std::string what = errorLoading(write("a.json", animatedWith(animation)));
        EXPECT_NE(what.find("a.json: /animation: has no tracks and /scene plays no glTF animation"), std::string::npos)
            << what;
    }
    // With a glTF animation to play, fps is its frame rate.
    nlohmann::json doc = nlohmann::json::parse(animatedWith(R"({"fps": 24})"));
    doc["scene"] = {{"gltf", fs::absolute(test::gltfFile("animated.gltf")).string()}, {"animation", "wave"}};
    const config::RenderConfig c = config::loadConfig(write("gltf.json", doc.dump()));
    EXPECT_FLOAT_EQ(c.animation.fps, 24.0f);
    EXPECT_TRUE(c.animation.empty());
    // Saved, it keeps its frame rate.
    EXPECT_EQ(config::configJson(c, dir / "saved.json")["animation"]["fps"], 24);
}

TEST(TrackEvaluation, FramesToPlayAreBounded)
{
    EXPECT_EQ(config::framesToPlay(2.0f, 30.0f), 61u);
    EXPECT_EQ(config::framesToPlay(0.0f, 30.0f), 1u);
    EXPECT_EQ(config::framesToPlay(3e38f, 1e4f), config::kMaxFrames);
    EXPECT_EQ(config::framesToPlay(std::numeric_limits<float>::quiet_NaN(), 30.0f), 1u);
}

TEST_F(HostileConfig, IncludesFanningOutAreRefusedAtTheFileLimit)
{
    // Each file includes the next 40 times: 40^2 files at three levels (40^5 at six).
    std::string forty = "[";
    for (int i = 0; i < 40; ++i) forty += std::string(i ? ", " : "") + "\"c.json\"";
    write("c.json", R"({"frames": 2})");
    write("b.json", R"({"include": )" + forty + "]}");
    std::string bs = "[";
    for (int i = 0; i < 40; ++i) bs += std::string(i ? ", " : "") + "\"b.json\"";
    const std::string what = errorLoading(write("a.json", R"({"include": )" + bs + "]}"));
    EXPECT_NE(what.find("b.json: /include/"), std::string::npos) << what;
    EXPECT_NE(what.find(fmt::format("c.json would be file {} of this config; a config loads at most {} files",
                                    config::kMaxConfigFiles + 1, config::kMaxConfigFiles)),
              std::string::npos)
        << what;
    EXPECT_NE(what.find("(include chain: a.json -> b.json)"), std::string::npos) << what;
}

TEST_F(HostileConfig, IncludesTogetherHoldAtMostTheConfigByteLimit)
{
    // Two loads of one file a little over half the limit: refused before the second read.
    std::ofstream(dir / "half.json", std::ios::binary) << std::string(config::kMaxConfigBytes / 2 + 16, ' ') << "{}";
    const std::string what = errorLoading(write("a.json", R"({"include": ["half.json", "half.json"]})"));
    EXPECT_NE(what.find("a.json: /include/1: " + (dir / "half.json").string() + ": the config and its includes come to"),
              std::string::npos)
        << what;
    EXPECT_NE(what.find("at most 64 MiB together (include chain: a.json)"), std::string::npos) << what;
}

TEST_F(HostileConfig, ParsingIsLinearInTheNumberOfObjects)
{
    // 100,000 empty objects (nlohmann's callback parser scanned each closing object's
    // parent: quadratic): the parse does a bounded number of steps per event, and its
    // value is the library's own parse.
    std::string text = R"({"camera": {"position": [0, 5, 10], "target": [0, 0, 0]}, "x": [)";
    for (int i = 0; i < 100000; ++i) text += i ? ",{}" : "{}";
    text += "]}";
    std::istringstream in(text);
    config::ConfigJsonWork work;
    const nlohmann::json parsed = config::parseConfigJson(in, "many.json", &work);
    EXPECT_EQ(parsed, nlohmann::json::parse(text));
    EXPECT_GE(work.events, 200000u);
    EXPECT_LE(work.events, 200020u);
    EXPECT_LE(work.steps, 2 * work.events);
    // Where each value came from is kept per object key, not per array element: as many
    // origins for 100,000 animation keys as for one.
    nlohmann::json doc = nlohmann::json::parse(animatedWith(R"({"fps": 30, "tracks": [{"target": "/camera/fov_y_deg",
        "keys": []}]})"));
    for (int i = 0; i < 100000; ++i) doc["animation"]["tracks"][0]["keys"].push_back({{"t", i * 0.01}, {"value", 45}});
    const config::ConfigDocument loaded = config::loadDocument(write("keys.json", doc.dump()));
    EXPECT_LE(loaded.origin.size(), 20u);
    EXPECT_EQ(loaded.fileFor("/animation/tracks/0/keys/99999/t"), (dir / "keys.json").string());
    EXPECT_EQ(config::parseConfig(loaded).animation.tracks[0].keys.size(), 100000u);
}

TEST_F(HostileConfig, SweepVariantsAreMadeOneAtATime)
{
    // 100 x 1,000 = 100,000 variants (the limit) of a config: counted, and any one made,
    // without making the others.
    nlohmann::json doc = nlohmann::json::parse(animatedWith(R"({"fps": 30, "tracks": [{"target": "/camera/fov_y_deg",
        "keys": [{"t": 0, "value": 40}]}]})"));
    nlohmann::json intensities = nlohmann::json::array(), cones = nlohmann::json::array();
    for (int i = 0; i < 100; ++i) intensities.push_back(i + 1);
    for (int i = 0; i < 1000; ++i) cones.push_back(1 + i * 0.08);
    doc["sweep"] = {{{"path", "/lights/0/intensity"}, {"values", intensities}},
                    {{"path", "/lights/0/outer_cone_deg"}, {"values", cones}}};
    const config::ConfigDocument loaded = config::loadDocument(write("sweep.json", doc.dump()));
    const config::SweepVariants variants(loaded);
    ASSERT_EQ(variants.size(), config::kMaxSweepCombinations);
    const config::SweepVariant last = variants.variant(variants.size() - 1);
    EXPECT_FLOAT_EQ(last.config.lights[0].light.intensity, 100.0f);
    EXPECT_FLOAT_EQ(last.config.lights[0].light.outerConeDeg, 1.0f + 999 * 0.08f);
    EXPECT_EQ(variants.label(12345), "/lights/0/intensity=13, /lights/0/outer_cone_deg=" + cones[345].dump());
    EXPECT_EQ(variants.variant(12345).label, variants.label(12345));
    // One value more is refused before any variant is made, naming the product.
    doc["sweep"][1]["values"].push_back(90);
    const std::string what = errorLoading(write("over.json", doc.dump()));
    EXPECT_NE(what.find("over.json: /sweep/1/values: the sweep has more than 100000 combinations: its entries up to "
                        "this one make 100 x 1001 = 100100 variants"),
              std::string::npos)
        << what;
}
