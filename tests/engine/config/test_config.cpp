#include "ScratchFolder.h"
#include "TestConfigs.h"  // support/: everyVariant
#include "TestPaths.h"  // support/: the build tree's paths

#include "penumbra/config/Config.h"
#include "penumbra/core/Error.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <glm/glm.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <set>
#include <fstream>
#include <unistd.h>

using namespace penumbra;
using nlohmann::json;
namespace fs = std::filesystem;

namespace {

json minimal()
{
    return json::parse(R"({
        "camera": {"position": [0, 5, 10], "target": [0, 0, 0]},
        "lights": [{"type": "spot", "position": [0, 10, 0], "target": [0, 0, 0], "outer_cone_deg": 40}]
    })");
}

std::string errorOf(const json& doc)
{
    try {
        config::parseConfig(doc, "scene.json");
    } catch (const ConfigError& e) {
        return e.what();
    }
    ADD_FAILURE() << "config was accepted: " << doc.dump();
    return {};
}

} // namespace

TEST(Config, DefaultConfigLoads)
{
    const config::RenderConfig c = config::loadConfig(penumbra::test::sourceDir() / "config/default.json");
    EXPECT_EQ(c.width, 1280u);
    EXPECT_EQ(c.height, 720u);
    ASSERT_EQ(c.lights.size(), 1u);
    ASSERT_NE(c.lights[0].shadow.param("resolution"), nullptr);
    EXPECT_EQ(*c.lights[0].shadow.param("resolution"), 2048);
    EXPECT_EQ(c.lights[0].shadow.technique, "hard");
    EXPECT_NEAR(glm::length(c.lights[0].light.direction), 1.0f, 1e-6f);
}

const fs::path kConfigs = penumbra::test::testDataDir() / "configs";

std::string loadError(const fs::path& file)
{
    try {
        config::loadConfig(file);
    } catch (const ConfigError& e) {
        return e.what();
    }
    ADD_FAILURE() << file << " was accepted";
    return {};
}

TEST(Config, EveryShippedConfigLoads)
{
    size_t count = 0;
    // config/ and its folders (bench/, bench/streets/), the JSON schema aside.
    for (const auto& entry : fs::recursive_directory_iterator(penumbra::test::sourceDir() / "config")) {
        if (entry.path().extension() != ".json" || entry.path().parent_path().filename() == "schema") continue;
        SCOPED_TRACE(entry.path().string());
        const config::ConfigDocument doc = config::loadDocument(entry.path());
        const std::vector<config::SweepVariant> variants = test::everyVariant(doc);
        EXPECT_FALSE(variants.empty());
        for (auto v : variants) EXPECT_NO_THROW(config::buildScene(v.config));
        ++count;
    }
    EXPECT_GE(count, 4u);
}

TEST(Config, IncludeMergesWithOverrides)
{
    const config::RenderConfig c = config::loadConfig(kConfigs / "include/override.json");
    EXPECT_EQ(c.width, 128u);   // overridden
    EXPECT_EQ(c.height, 36u);   // kept from the base (objects merge key by key)
    EXPECT_FLOAT_EQ(c.camera.position.x, 15.0f);
    ASSERT_EQ(c.lights.size(), 1u);  // arrays are replaced whole
    EXPECT_EQ(c.lights[0].light.type, scene::LightType::Point);
}


TEST(Config, ErrorInIncludingFileNamesThatFile)
{
    const std::string what = loadError(kConfigs / "include/bad_override.json");
    EXPECT_NE(what.find("bad_override.json: /output/width: must be an integer in [1, 16384], got 0"), std::string::npos) << what;
}

TEST(Config, ErrorInIncludedFileNamesTheIncludedFile)
{
    const std::string what = loadError(kConfigs / "include/uses_bad_base.json");
    EXPECT_NE(what.find("bad_in_base.json: /camera/fov_y_deg: must be in (0, 179], got 500"), std::string::npos) << what;
}

TEST(Config, IncludeCycleIsNamed)
{
    const std::string what = loadError(kConfigs / "include/cycle_a.json");
    EXPECT_NE(what.find("include cycle: cycle_a.json -> cycle_b.json -> cycle_a.json"), std::string::npos) << what;
}

TEST(Config, MissingIncludeIsNamed)
{
    json doc = minimal();
    const test::ScratchFolder scratch("cfg");
    const fs::path& dir = scratch.path;
    doc["include"] = "nowhere.json";
    std::ofstream(dir / "a.json") << doc.dump();
    const std::string what = loadError(dir / "a.json");
    EXPECT_NE(what.find("a.json: /include: included file not found"), std::string::npos) << what;
}

TEST(Config, SweepExpandsTheCartesianProduct)
{
    const config::ConfigDocument doc = config::loadDocument(penumbra::test::sourceDir() / "config/sweep-resolution.json");
    const std::vector<config::SweepVariant> v = test::everyVariant(doc);
    ASSERT_EQ(v.size(), 8u);
    EXPECT_EQ(*v[0].config.lights[0].shadow.param("resolution"), 512);
    EXPECT_EQ(*v[0].config.lights[0].shadow.param("slope_bias"), 1.0);
    EXPECT_EQ(*v[1].config.lights[0].shadow.param("slope_bias"), 2.0);
    EXPECT_EQ(*v[7].config.lights[0].shadow.param("resolution"), 4096);
    EXPECT_EQ(v[7].label, "/lights/0/shadow/resolution=4096, /lights/0/shadow/slope_bias=2.0");
    // The base run ignores the sweep.
    EXPECT_EQ(*config::parseConfig(doc).lights[0].shadow.param("resolution"), 2048);
}

TEST(Config, BadSweepValueNamesTheSweepEntry)
{
    config::ConfigDocument doc;
    doc.file = "sweep.json";
    doc.json = minimal();
    doc.json["sweep"] = json::array({{{"path", "/lights/0/intensity"}, {"values", {1, -5}}}});
    try {
        test::everyVariant(doc);
        FAIL() << "expected ConfigError";
    } catch (const ConfigError& e) {
        EXPECT_NE(std::string(e.what()).find("sweep.json (/sweep/0/values/1): /lights/0/intensity: must be in [0,"),
                  std::string::npos) << e.what();
    }
    doc.json["sweep"] = json::array({{{"path", "/nothing/here"}, {"values", {1}}}});
    EXPECT_THROW(test::everyVariant(doc), ConfigError);
}

namespace {

// The message making the variants throws for `doc` (file "sweep.json").
std::string sweepError(const json& doc)
{
    config::ConfigDocument d;
    d.file = "sweep.json";
    d.json = doc;
    try {
        test::everyVariant(d);
    } catch (const ConfigError& e) {
        return e.what();
    }
    ADD_FAILURE() << "sweep was accepted: " << doc.dump();
    return {};
}

std::vector<config::SweepVariant> expand(const json& doc)
{
    config::ConfigDocument d;
    d.file = "sweep.json";
    d.json = doc;
    return test::everyVariant(d);
}

bool has(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

} // namespace

TEST(Config, SweptObjectReplacesTheObjectWhole)
{
    // A technique and its parameters change together: nothing of the base "shadow" object
    // (its resolution) survives into a variant that replaces it.
    json doc = minimal();
    doc["lights"][0]["shadow"] = {{"technique", "hard"}, {"resolution", 512}};
    doc["sweep"] = json::parse(R"([{"path": "/lights/0/shadow", "labels": ["pcss", "vsm"],
        "values": [{"technique": "pcss", "blocker_samples": 8}, {"technique": "vsm", "variant": "evsm"}]}])");
    const std::vector<config::SweepVariant> v = expand(doc);
    ASSERT_EQ(v.size(), 2u);
    EXPECT_EQ(v[0].config.lights[0].shadow.technique, "pcss");
    EXPECT_EQ(*v[0].config.lights[0].shadow.param("blocker_samples"), 8);
    EXPECT_EQ(v[0].config.lights[0].shadow.param("resolution"), nullptr);
    EXPECT_EQ(v[1].config.lights[0].shadow.technique, "vsm");
    EXPECT_EQ(*v[1].config.lights[0].shadow.param("variant"), "evsm");
    EXPECT_EQ(v[1].label, "/lights/0/shadow=vsm");
    ASSERT_EQ(v[1].choices.size(), 1u);
    EXPECT_EQ(v[1].choices[0].paths, std::vector<std::string>{"/lights/0/shadow"});
    EXPECT_EQ(v[1].choices[0].value, 1u);
    EXPECT_EQ(v[1].choices[0].label, "vsm");
    EXPECT_TRUE(v[1].choices[0].labelled);
    // Where a parameter came from: the swept value, not the base object it replaced.
    EXPECT_EQ(v[1].config.lights[0].shadow.params[0].where, "sweep.json (/sweep/0/values/1): /lights/0/shadow/variant");
}

TEST(Config, LaterSweepEntriesSetValuesInsideEarlierOnes)
{
    // The first entry varies slowest; the second sets a parameter inside the object the
    // first swept, in every variant.
    json doc = minimal();
    doc["lights"][0]["shadow"] = {{"technique", "hard"}};
    doc["sweep"] = json::parse(R"([{"path": "/lights/0/shadow", "values": [{"technique": "a"}, {"technique": "b"}]},
                                    {"path": "/lights/0/shadow/resolution", "values": [256, 512, 1024]}])");
    const std::vector<config::SweepVariant> v = expand(doc);
    ASSERT_EQ(v.size(), 6u);
    for (size_t i = 0; i < v.size(); ++i) {
        EXPECT_EQ(v[i].config.lights[0].shadow.technique, i < 3 ? "a" : "b") << i;
        EXPECT_EQ(*v[i].config.lights[0].shadow.param("resolution"), 256 << (i % 3)) << i;
    }
    EXPECT_EQ(v[4].label, R"(/lights/0/shadow={"technique":"b"}, /lights/0/shadow/resolution=512)");
    EXPECT_FALSE(v[4].choices[1].labelled);
    EXPECT_EQ(v[4].choices[1].label, "512");
}

TEST(Config, SweepPathsSetSeveralValuesTogether)
{
    json doc = minimal();
    doc["sweep"] = json::parse(R"([{"paths": ["/scene", "/camera/fov_y_deg"], "labels": ["grid", "fence"], "values": [
        [{"generator": "box-grid", "params": {"rows": 2}}, 30],
        [{"generator": "fence", "scale": 2}, 60]]}])");
    const std::vector<config::SweepVariant> v = expand(doc);
    ASSERT_EQ(v.size(), 2u);
    EXPECT_EQ(v[0].config.scene.parts[0].generator, "box-grid");
    EXPECT_FLOAT_EQ(v[0].config.camera.fovYDeg, 30.0f);
    EXPECT_EQ(v[1].config.scene.parts[0].generator, "fence");
    EXPECT_EQ(v[1].config.scene.parts[0].transform.scale, glm::dvec3(2.0));
    EXPECT_FLOAT_EQ(v[1].config.camera.fovYDeg, 60.0f);
    EXPECT_EQ(v[1].label, "/scene+/camera/fov_y_deg=fence");
    EXPECT_EQ(v[1].choices[0].paths, (std::vector<std::string>{"/scene", "/camera/fov_y_deg"}));
    // A bad value inside names its own place in the sweep.
    doc["sweep"][0]["values"][1][1] = 500;
    EXPECT_TRUE(has(sweepError(doc), "sweep.json (/sweep/0/values/1/1): /camera/fov_y_deg: must be in (0, 179], got 500"))
        << sweepError(doc);
}

TEST(Config, BadSweepEntriesNameTheirJsonPath)
{
    const auto withSweep = [](const char* sweep) {
        json doc = minimal();
        doc["sweep"] = json::parse(sweep);
        return sweepError(doc);
    };
    const std::vector<std::pair<const char*, const char*>> cases = {
        {R"([{"path": "lights/0/intensity", "values": [1]}])", "sweep.json: /sweep/0/path: \"lights/0/intensity\" is not a JSON pointer"},
        {R"([{"path": "/nothing/here", "values": [1]}])", "sweep.json: /sweep/0/path: \"/nothing/here\": the config has no \"/nothing\" to set it in"},
        {R"([{"path": "/lights/3/intensity", "values": [1]}])", "sweep.json: /sweep/0/path: \"/lights/3/intensity\": the config has no \"/lights/3\""},
        {R"([{"path": "/lights/1", "values": [{}]}])", "sweep.json: /sweep/0/path: \"/lights/1\": \"/lights\" has 1 elements; a sweep replaces an element, it does not add one"},
        {R"([{"path": "/sweep", "values": [1]}])", "sweep.json: /sweep/0/path: cannot sweep \"/sweep\""},
        {R"([{"path": 3, "values": [1]}])", "sweep.json: /sweep/0/path: must be a JSON pointer string"},
        {R"([{"values": [1]}])", "sweep.json: /sweep/0: give either \"path\" (one JSON pointer) or \"paths\" (several)"},
        {R"([{"path": "/frames", "paths": ["/frames"], "values": [1]}])", "sweep.json: /sweep/0: give either"},
        {R"([{"paths": [], "values": [1]}])", "sweep.json: /sweep/0/paths: must be a non-empty array of JSON pointers"},
        {R"([{"paths": ["/camera", "/camera/fov_y_deg"], "values": [[{}, 1]]}])",
         "sweep.json: /sweep/0/paths/1: \"/camera/fov_y_deg\" lies inside \"/camera\", which the same entry sets"},
        {R"([{"paths": ["/frames", "/output/width"], "values": [[1, 2], [3]]}])",
         "sweep.json: /sweep/0/values/1: must be an array of 2 values, one per path, got [3]"},
        {R"([{"path": "/frames", "values": []}])", "sweep.json: /sweep/0/values: must be a non-empty array"},
        {R"([{"path": "/frames", "values": [1, 2], "labels": ["one"]}])", "sweep.json: /sweep/0/labels: must be an array of 2 strings, one per value"},
        {R"([{"path": "/frames", "values": [1, 2], "labels": ["one", ""]}])", "sweep.json: /sweep/0/labels/1: must be a non-empty string"},
        {R"([{"path": "/frames", "values": [1, 2], "labels": ["one", "one"]}])", "sweep.json: /sweep/0/labels/1: \"one\" labels another value already"},
        {R"([{"path": "/frames", "values": [1], "label": ["one"]}])", "sweep.json: /sweep/0/label: unknown key; did you mean \"labels\"?"},
        // The parent exists in one variant only: the message names the variant.
        {R"([{"path": "/lights/0/shadow", "values": [{"technique": "a"}, 5]}, {"path": "/lights/0/shadow/resolution", "values": [1]}])",
         "sweep.json: /sweep/1/path: \"/lights/0/shadow/resolution\": the config has no \"/lights/0/shadow\" to set it in (in the variant /lights/0/shadow=5)"},
    };
    for (const auto& [sweep, message] : cases) {
        const std::string what = withSweep(sweep);
        EXPECT_TRUE(has(what, message)) << sweep << "\n  got: " << what << "\n  expected: " << message;
    }
}

TEST(Config, SweepVariantsCountsTheVariantsWithoutMakingThem)
{
    const config::ConfigDocument doc = config::loadDocument(penumbra::test::sourceDir() / "config/sweep-resolution.json");
    EXPECT_EQ(config::SweepVariants(doc).size(), test::everyVariant(doc).size());
    config::ConfigDocument plain{"plain.json", minimal(), {}};
    EXPECT_EQ(config::SweepVariants(plain).size(), 1u);
    // 2 x 3 x (paths together) 2; at the limit and one entry past it.
    config::ConfigDocument swept{"sweep.json", minimal(), {}};
    swept.json["sweep"] = json::parse(R"([{"path": "/lights/0/intensity", "values": [1, 2]},
        {"path": "/camera/position", "values": [[0, 5, 10], [0, 6, 10], [0, 7, 10]]},
        {"paths": ["/lights/0/outer_cone_deg", "/camera/target"], "values": [[40, [0, 0, 0]], [50, [1, 0, 0]]]}])");
    EXPECT_EQ(config::SweepVariants(swept).size(), 12u);
    EXPECT_EQ(test::everyVariant(swept).size(), 12u);
    json values = json::array();
    for (size_t i = 0; i < config::kMaxSweepCombinations / 10; ++i) values.push_back(i + 1);
    swept.json["sweep"] = json::array({{{"path", "/lights/0/intensity"}, {"values", values}},
                                       {{"path", "/lights/0/outer_cone_deg"}, {"values", json::array({1, 2, 3, 4, 5, 6, 7, 8, 9, 10})}}});
    EXPECT_EQ(config::SweepVariants(swept).size(), config::kMaxSweepCombinations);
    swept.json["sweep"][1]["values"].push_back(11);
    try {
        const config::SweepVariants refused(swept);
        ADD_FAILURE() << "more than kMaxSweepCombinations variants are refused";
    } catch (const ConfigError& e) {
        EXPECT_TRUE(has(e.what(), "sweep.json: /sweep/1/values: the sweep has more than 100000 combinations")) << e.what();
    }
    // A malformed entry is refused before any variant is made.
    swept.json["sweep"] = json::parse(R"([{"path": "lights/0/intensity", "values": [1]}])");
    EXPECT_THROW(config::SweepVariants{swept}, ConfigError);
}

TEST(Config, TheTradeoffBenchmarkCoversEveryTechniqueAtTwoLightSizesOnFourScenes)
{
    // config/bench/tradeoff.json (docs/tradeoff.md): every variant parses and builds its
    // scene; its plugins are checked by `penumbra validate`. The scenes include a grazing
    // sun (8° above the horizon) and a contact (a slab 7.7 cm over the ground).
    const config::ConfigDocument doc = config::loadDocument(penumbra::test::sourceDir() / "config/bench/tradeoff.json");
    const std::vector<config::SweepVariant> variants = test::everyVariant(doc);
    ASSERT_EQ(variants.size(), 4u * 2u * 9u);
    std::set<std::string> scenes, techniques, labels, sceneLabels;
    std::set<float> sizes;
    float lowestSun = 90.0f;
    for (config::SweepVariant v : variants) {
        SCOPED_TRACE(v.label);
        scenes.insert(v.config.scene.parts[0].generator);
        sceneLabels.insert(v.choices[0].label);
        sizes.insert(v.config.lights[0].light.angularDiameterDeg);
        techniques.insert(v.config.lights[0].shadow.technique);
        labels.insert(v.choices[2].label);
        const glm::vec3 d = glm::normalize(v.config.lights[0].light.direction);
        lowestSun = std::min(lowestSun, glm::degrees(std::asin(-d.y)));
        EXPECT_NO_THROW(config::buildScene(v.config));
    }
    EXPECT_EQ(scenes, (std::set<std::string>{"box-grid", "fence", "penumbra"}));
    EXPECT_EQ(sceneLabels.size(), 4u);
    EXPECT_EQ(sizes.size(), 2u);
    EXPECT_LT(lowestSun, 10.0f) << "a grazing sun";
    EXPECT_EQ(techniques, (std::set<std::string>{"hard", "pcss", "vsm", "vssm", "backprojection"}));
    EXPECT_EQ(labels, (std::set<std::string>{"hard", "pcf 5x5", "poisson 32", "pcss", "vsm", "evsm", "esm", "vssm",
                                             "backprojection"}));
}

TEST(Config, LightTypesAndTheirKeys)
{
    json doc = minimal();
    doc["lights"] = json::parse(R"([
        {"type": "directional", "direction": [0, -1, 0], "angular_diameter_deg": 0.53, "intensity": 3},
        {"type": "point", "position": [0, 5, 0]},
        {"type": "rect", "position": [0, 5, 0], "target": [0, 0, 0], "size": [2, 1]},
        {"type": "disk", "position": [0, 5, 0], "direction": [0, -1, 0], "radius": 0.5}])");
    const config::RenderConfig c = config::parseConfig(doc, "scene.json");
    ASSERT_EQ(c.lights.size(), 4u);
    EXPECT_EQ(c.lights[0].light.type, scene::LightType::Directional);
    EXPECT_FLOAT_EQ(c.lights[0].light.angularDiameterDeg, 0.53f);
    EXPECT_FLOAT_EQ(c.lights[2].light.sizeWorld.x, 2.0f);
    EXPECT_NEAR(glm::dot(c.lights[2].light.tangent, c.lights[2].light.direction), 0.0f, 1e-6f);
    EXPECT_FLOAT_EQ(c.lights[3].light.radiusWorld, 0.5f);

    doc["lights"] = json::parse(R"([{"type": "point", "position": [0, 5, 0], "outer_cone_deg": 30}])");
    EXPECT_NE(errorOf(doc).find("/lights/0/outer_cone_deg: unknown key for a point light"), std::string::npos);
    doc["lights"] = json::parse(R"([{"type": "rect", "position": [0, 5, 0], "direction": [0, -1, 0], "size": [2, -1]}])");
    EXPECT_NE(errorOf(doc).find("/lights/0/size/1: must be in [0,"), std::string::npos);
    // Size 0 is a light of size 0 (a point that emits like the rect or disk), as the
    // reference and every technique take it.
    doc["lights"] = json::parse(R"([{"type": "rect", "position": [0, 5, 0], "direction": [0, -1, 0], "size": [0, 0]},
                                    {"type": "disk", "position": [0, 5, 0], "direction": [0, -1, 0], "radius": 0}])");
    const config::RenderConfig zero = config::parseConfig(doc, "scene.json");
    EXPECT_EQ(zero.lights[0].light.sizeWorld, glm::vec2(0.0f));
    EXPECT_EQ(zero.lights[1].light.radiusWorld, 0.0f);
    doc["lights"] = json::parse(R"([{"type": "disk", "position": [0, 5, 0], "direction": [0, -1, 0]}])");
    EXPECT_NE(errorOf(doc).find("/lights/0/radius: is required"), std::string::npos);
    doc["lights"] = json::parse(R"([{"type": "directional", "direction": [0, 0, 0]}])");
    EXPECT_NE(errorOf(doc).find("/lights/0/direction: must be non-zero"), std::string::npos);
    doc["lights"] = json::parse(R"([{"type": "area", "position": [0, 5, 0]}])");
    EXPECT_NE(errorOf(doc).find("/lights/0/type: must be one of directional, spot, point, rect, disk"), std::string::npos);
}

TEST(Config, CullingMode)
{
    json doc = minimal();
    doc["culling"] = "receiver-mask";
    EXPECT_EQ(config::parseConfig(doc, "scene.json").culling, config::CullingMode::ReceiverMask);
    doc["culling"] = "receiver";
    EXPECT_NE(errorOf(doc).find("/culling: must be one of none, frustum, light-occlusion, receiver-mask"), std::string::npos);
}

TEST(Config, ShadowFocusNeedsAnOcclusionMode)
{
    json doc = minimal();
    EXPECT_FALSE(config::parseConfig(doc, "scene.json").shadowFocus);
    doc["culling"] = "receiver-mask";
    doc["shadow_focus"] = true;
    EXPECT_TRUE(config::parseConfig(doc, "scene.json").shadowFocus);
    doc["shadow_focus"] = "yes";
    EXPECT_NE(errorOf(doc).find("/shadow_focus: must be true or false, got \"yes\""), std::string::npos) << errorOf(doc);
    doc["shadow_focus"] = true;
    doc["culling"] = "frustum";
    EXPECT_NE(errorOf(doc).find("/shadow_focus: needs culling \"receiver-mask\""), std::string::npos) << errorOf(doc);
}

TEST(Config, NotesAreMarkdownParagraphs)
{
    json doc = minimal();
    EXPECT_TRUE(config::parseConfig(doc, "scene.json").notes.empty());
    doc["notes"] = {"One.", "Two *words*."};
    EXPECT_EQ(config::parseConfig(doc, "scene.json").notes, (std::vector<std::string>{"One.", "Two *words*."}));
    doc["notes"] = "One.";
    EXPECT_NE(errorOf(doc).find("/notes: must be an array of Markdown paragraphs"), std::string::npos) << errorOf(doc);
    doc["notes"] = {"One.", 2};
    EXPECT_NE(errorOf(doc).find("/notes/1: must be a non-empty string"), std::string::npos) << errorOf(doc);
    doc["notes"] = {"One.", ""};
    EXPECT_NE(errorOf(doc).find("/notes/1: must be a non-empty string"), std::string::npos) << errorOf(doc);
}

TEST(Config, DrawBatchingIsBatchedOrPerInstance)
{
    json doc = minimal();
    EXPECT_TRUE(config::parseConfig(doc, "scene.json").batchDraws);
    doc["draw_batching"] = "per-instance";
    EXPECT_FALSE(config::parseConfig(doc, "scene.json").batchDraws);
    doc["draw_batching"] = "instanced";
    EXPECT_NE(errorOf(doc).find("/draw_batching: must be one of batched, per-instance"), std::string::npos)
        << errorOf(doc);
}

TEST(Config, AnimationTracksAreValidated)
{
    json doc = minimal();
    doc["animation"] = json::parse(R"({"tracks": [{"target": "/camera/position", "keys": [{"t": 0, "value": [0, 5, 10]}, {"t": 0, "value": [1, 5, 10]}]}]})");
    EXPECT_NE(errorOf(doc).find("/animation/tracks/0/keys/1/t: key times must increase strictly"), std::string::npos);
    doc["animation"] = json::parse(R"({"tracks": [{"target": "/lights/3/position", "keys": [{"t": 0, "value": [0, 5, 10]}]}]})");
    EXPECT_NE(errorOf(doc).find("/animation/tracks/0/target: unknown target \"/lights/3/position\""), std::string::npos);
    doc["animation"] = json::parse(R"({"tracks": [{"target": "/lights/99999999999999999999/color", "keys": [{"t": 0, "value": [0, 5, 10]}]}]})");
    EXPECT_NE(errorOf(doc).find("/animation/tracks/0/target: unknown target"), std::string::npos);
    doc["animation"] = json::parse(R"({"tracks": [{"target": "/camera/fov_y_deg", "keys": [{"t": 0, "value": [1, 2, 3]}]}]})");
    EXPECT_NE(errorOf(doc).find("/animation/tracks/0/keys/0/value: must be a number"), std::string::npos);
    doc["animation"] = json::parse(R"({"tracks": [{"target": "node:nobody/translation", "keys": [{"t": 0, "value": [1, 2, 3]}]}]})");
    config::RenderConfig c = config::parseConfig(doc, "scene.json");  // the node is checked with the scene
    try {
        config::buildScene(c);
        FAIL() << "expected ConfigError";
    } catch (const ConfigError& e) {
        EXPECT_NE(std::string(e.what()).find("/animation/tracks/0/target: the scene has no node named \"nobody\""),
                  std::string::npos) << e.what();
    }
}

TEST(Animation, Interpolates)
{
    config::AnimationTrack track{"/camera/fov_y_deg", config::Interpolation::Linear, {{1.0f, {10.0f}}, {3.0f, {30.0f}}}};
    EXPECT_FLOAT_EQ(config::evaluate(track, 0.0f)[0], 10.0f);  // before the first key
    EXPECT_FLOAT_EQ(config::evaluate(track, 2.0f)[0], 20.0f);
    EXPECT_FLOAT_EQ(config::evaluate(track, 9.0f)[0], 30.0f);  // after the last key
    track.interpolation = config::Interpolation::Step;
    EXPECT_FLOAT_EQ(config::evaluate(track, 2.9f)[0], 10.0f);
    track.interpolation = config::Interpolation::Smooth;
    track.keys.push_back({4.0f, {30.0f}});
    // Passes through every key; between two equal keys after a rise it stays finite.
    EXPECT_FLOAT_EQ(config::evaluate(track, 3.0f)[0], 30.0f);
    const float mid = config::evaluate(track, 2.0f)[0];
    EXPECT_GT(mid, 10.0f);
    EXPECT_LT(mid, 30.0f);
    EXPECT_TRUE(std::isfinite(config::evaluate(track, 3.5f)[0]));
}

TEST(Animation, MovesCameraLightsAndNodes)
{
    config::RenderConfig c = config::loadConfig(penumbra::test::sourceDir() / "config/animated.json");
    scene::Scene s = config::buildScene(c);
    const glm::vec3 before = c.lights[0].light.direction;
    config::applyAnimation(c.animation, 1.0f, c, s);
    EXPECT_FLOAT_EQ(c.camera.position.x, -4.0f);
    EXPECT_FLOAT_EQ(c.lights[0].light.position.x, 0.0f);
    EXPECT_GT(glm::length(c.lights[0].light.direction - before), 0.1f);  // still aimed at its target
    EXPECT_NEAR(glm::length(c.lights[0].light.direction), 1.0f, 1e-5f);
    const std::vector<uint32_t> moved = s.updateTransforms();
    ASSERT_EQ(moved.size(), 1u);
    EXPECT_NEAR(s.instances[moved[0]].worldBounds.center().y, 5.0f, 1e-4f);
}

TEST(Config, GeneratorParametersAreCheckedByName)
{
    json doc = minimal();
    doc["scene"] = {{"generator", "city"}, {"params", {{"blocks", 2}, {"seed", 3}}}};
    config::RenderConfig c = config::parseConfig(doc, "scene.json");
    EXPECT_EQ(c.scene.parts[0].generator, "city");
    EXPECT_EQ(c.scene.parts[0].params.size(), 2u);
    EXPECT_GT(config::buildScene(c).instances.size(), 100u);

    doc["scene"]["params"] = {{"block", 2}};
    EXPECT_NE(errorOf(doc).find("/scene/params/block: unknown key for the city generator; did you mean \"blocks\"?"),
              std::string::npos) << errorOf(doc);
    // A value out of its range or not of its type, where the file gives it, with what it
    // must be from the generator's table.
    doc["scene"]["params"] = {{"blocks", 0}};
    EXPECT_NE(errorOf(doc).find("/scene/params/blocks: must be a whole number in [1, 128] (generator city, parameter "
                                "blocks: blocks per side of the square city (blocks² in all)), got 0"),
              std::string::npos)
        << errorOf(doc);
    doc["scene"]["params"] = {{"car_density", "lots"}};
    EXPECT_NE(errorOf(doc).find("/scene/params/car_density: must be a number in [0, 1] (generator city, "), std::string::npos)
        << errorOf(doc);
    doc["scene"]["params"] = {{"seed", true}};
    EXPECT_NE(errorOf(doc).find("/scene/params/seed: must be a whole number in [0, 4294967295]"), std::string::npos)
        << errorOf(doc);
    // A bound between parameters is the generator's, when the scene is built.
    doc["scene"]["params"] = {{"block_size", 40}, {"sidewalk_width", 20}};
    try {
        config::RenderConfig bad = config::parseConfig(doc, "scene.json");
        config::buildScene(bad);
        FAIL() << "expected ConfigError";
    } catch (const ConfigError& e) {
        EXPECT_NE(std::string(e.what()).find("scene.json: /scene: city: sidewalk_width must be in [1.5, 10], got 20"),
                  std::string::npos)
            << e.what();
    }
    doc["scene"] = {{"generator", "forest"}};
    EXPECT_NE(errorOf(doc).find("/scene/generator: must be one of box-grid, penumbra, city, hair, fence"), std::string::npos);
}

TEST(Config, LightsFromAGltfScene)
{
    config::RenderConfig c = config::loadConfig(kConfigs / "gltf_scene_lights.json");
    EXPECT_TRUE(c.lightsFromScene);
    EXPECT_TRUE(c.lights.empty());
    const scene::Scene s = config::buildScene(c);
    ASSERT_EQ(c.lights.size(), 3u);  // hierarchy.gltf: directional, spot, point
    std::set<scene::LightType> types;
    for (const auto& l : c.lights) types.insert(l.light.type);
    EXPECT_EQ(types.size(), 3u);
    // Named as the file names them, for compare's files and bench's tables.
    std::set<std::string> names;
    for (const auto& l : c.lights) names.insert(l.name);
    EXPECT_EQ(names, (std::set<std::string>{"sun", "lamp", "bulb"}));
    EXPECT_FALSE(s.instances.empty());

    json doc = minimal();
    doc["lights"] = "scene";
    EXPECT_NE(errorOf(doc).find("/lights: \"scene\" takes the lights of a glTF scene"), std::string::npos);
}

TEST(Config, SceneLightsWithoutANameOrWithATakenOneAreNumbered)
{
    // hierarchy.gltf (data URIs only) with its lights named "", "sun", "sun".
    std::ifstream in(penumbra::test::testDataDir() / "gltf/hierarchy.gltf");
    json gltf = json::parse(in);
    json& lights = gltf["extensions"]["KHR_lights_punctual"]["lights"];
    lights[0].erase("name");
    lights[1]["name"] = "sun";
    lights[2]["name"] = "sun";
    const test::ScratchFolder scratch("scene_lights");
    const fs::path& dir = scratch.path;
    std::ofstream(dir / "named.gltf") << gltf.dump();
    std::ofstream(dir / "config.json") << R"({"scene": {"gltf": "named.gltf"},
        "camera": {"position": [6, 8, 12], "target": [0, 0, 0]}, "lights": "scene"})";
    config::RenderConfig c = config::loadConfig(dir / "config.json");
    config::buildScene(c);
    ASSERT_EQ(c.lights.size(), 3u);
    // The lights come in node order: one of the two "sun"s keeps the name; the nameless one
    // is light0 (its index in the file, as the loader names it), the other "sun" is
    // numbered by its place; no two alike.
    std::set<std::string> names;
    for (const auto& l : c.lights) names.insert(l.name);
    EXPECT_EQ(names.size(), 3u);
    EXPECT_EQ(names.count("sun"), 1u);
    EXPECT_EQ(names.count("light0"), 1u);
    for (const std::string& n : names) EXPECT_TRUE(n == "sun" || n.rfind("light", 0) == 0) << n;
}

TEST(Config, CommittedAssetMatchesItsGenerator)
{
    // assets/penumbra.glb is `penumbra generate penumbra`: loading it gives the scene the
    // generator makes (config/penumbra-gltf.json swaps the generator for the file).
    config::RenderConfig fromFile = config::loadConfig(penumbra::test::sourceDir() / "config/penumbra-gltf.json");
    config::RenderConfig generated = config::loadConfig(penumbra::test::sourceDir() / "config/penumbra-scene.json");
    ASSERT_EQ(fromFile.scene.parts[0].kind, config::ScenePart::Kind::Gltf);
    const scene::Scene a = config::buildScene(fromFile), b = config::buildScene(generated);
    EXPECT_EQ(a.triangleCount(), b.triangleCount());
    EXPECT_EQ(a.instances.size(), b.instances.size());
    for (int i = 0; i < 3; ++i) {
        EXPECT_NEAR(a.bounds().min[i], b.bounds().min[i], 1e-5f);
        EXPECT_NEAR(a.bounds().max[i], b.bounds().max[i], 1e-5f);
    }
}

TEST(Config, MinimalConfigGetsDefaults)
{
    const config::RenderConfig c = config::parseConfig(minimal(), "scene.json");
    EXPECT_EQ(c.frames, 1u);
    EXPECT_EQ(c.scene.parts[0].generator, "box-grid");
    EXPECT_FLOAT_EQ(c.lights[0].light.outerConeDeg, 40.0f);
    EXPECT_LE(c.lights[0].light.innerConeDeg, 40.0f);
}

TEST(Config, OutOfRangeNamesFilePathAndValue)
{
    json doc = minimal();
    doc["lights"][0]["outer_cone_deg"] = 120;
    const std::string what = errorOf(doc);
    EXPECT_NE(what.find("scene.json: /lights/0/outer_cone_deg: must be in (0, 89], got 120"), std::string::npos) << what;
}

TEST(Config, NegativeSizeIsRejected)
{
    json doc = minimal();
    doc["output"] = {{"width", -2}, {"height", 10}};
    EXPECT_NE(errorOf(doc).find("/output/width: must be an integer in [1, 16384], got -2"), std::string::npos);
}

TEST(Config, UnknownKeySuggestsTheClosest)
{
    json doc = minimal();
    doc["lights"][0]["intensty"] = 5;
    const std::string what = errorOf(doc);
    EXPECT_NE(what.find("/lights/0/intensty: unknown key for a spot light; did you mean \"intensity\"?"), std::string::npos) << what;
}

TEST(Config, UnknownKeyFarFromAnyListsTheKnownOnes)
{
    json doc = minimal();
    doc["zzzzzzzz"] = 1;
    const std::string what = errorOf(doc);
    EXPECT_NE(what.find("/zzzzzzzz: unknown key (expected one of:"), std::string::npos) << what;
}

TEST(Config, MissingRequiredField)
{
    json doc = minimal();
    doc.erase("camera");
    EXPECT_NE(errorOf(doc).find("scene.json: /camera: is required but missing"), std::string::npos);
}

TEST(Config, WrongTypes)
{
    json doc = minimal();
    doc["camera"]["position"] = {1, 2};
    EXPECT_NE(errorOf(doc).find("/camera/position: must be an array of 3 numbers"), std::string::npos);
    doc = minimal();
    doc["lights"] = json::object();
    EXPECT_NE(errorOf(doc).find("/lights: must be a non-empty array"), std::string::npos);
    doc = minimal();
    // Technique names are checked against the plugins when they load; here only the form.
    doc["lights"][0]["shadow"] = {{"technique", "Ray Traced"}};
    EXPECT_NE(errorOf(doc).find("/lights/0/shadow/technique: must be a plugin name ([a-z0-9_-]+, at most 243 characters), "
                                "got \"Ray Traced\""),
              std::string::npos);
    doc["lights"][0]["shadow"] = {{"technique", "hard"}, {"required", "yes"}};
    EXPECT_NE(errorOf(doc).find("/lights/0/shadow/required: must be true or false"), std::string::npos);
    // "none" is an unshadowed light: no plugin, so no parameters either.
    doc["lights"][0]["shadow"] = {{"technique", "none"}, {"resolution", 512}};
    EXPECT_NE(errorOf(doc).find("/lights/0/shadow/resolution: technique \"none\" (an unshadowed light) takes no parameters"),
              std::string::npos);
    doc["lights"][0]["shadow"] = {{"technique", "none"}};
    EXPECT_TRUE(config::parseConfig(doc, "none.json").lights[0].shadow.unshadowed());
}

TEST(Config, DegenerateGeometryIsRejected)
{
    json doc = minimal();
    doc["camera"]["target"] = doc["camera"]["position"];
    EXPECT_NE(errorOf(doc).find("/camera/target: must differ"), std::string::npos);
    doc = minimal();
    doc["camera"]["up"] = {0, 0, 0};
    EXPECT_NE(errorOf(doc).find("/camera/up:"), std::string::npos);
    doc = minimal();
    doc["lights"][0]["inner_cone_deg"] = 50;
    EXPECT_NE(errorOf(doc).find("/lights/0/inner_cone_deg: must be <= outer_cone_deg"), std::string::npos);
}

TEST(Config, TooManyLights)
{
    json doc = minimal();
    for (int i = 0; i < 9; ++i) doc["lights"].push_back(doc["lights"][0]);
    EXPECT_NE(errorOf(doc).find("/lights: at most 8 lights"), std::string::npos);
}

TEST(Config, MalformedJsonNamesLine)
{
    const fs::path file = penumbra::test::testDataDir() / "configs/malformed.json";
    try {
        config::loadConfig(file);
        FAIL() << "expected ConfigError";
    } catch (const ConfigError& e) {
        const std::string what = e.what();
        EXPECT_NE(what.find("malformed.json: malformed JSON"), std::string::npos) << what;
        EXPECT_NE(what.find("line 4"), std::string::npos) << what;
    }
}

TEST(Config, MissingFile)
{
    try {
        config::loadConfig("/nonexistent/penumbra.json");
        FAIL() << "expected ConfigError";
    } catch (const ConfigError& e) {
        EXPECT_NE(std::string(e.what()).find("/nonexistent/penumbra.json: config file not found"), std::string::npos);
    }
}

TEST(Run, TheScenesLightsExistBeforeTheOverridesApply)
{
    // "lights": "scene": the lights come with the glTF file, so --set (which names their
    // technique, "hard" by default) can reach them only once the scene is loaded.
    config::RunOptions options;
    options.overrides = config::parseParamOverrides({"hard.resolution=512"});
    options.width = 32;
    options.height = 24;
    options.frames = 3;
    options.culling = config::CullingMode::ReceiverMask;
    const config::PreparedRun run = config::prepareRun(kConfigs / "gltf_scene_lights.json", options);
    ASSERT_EQ(run.config.lights.size(), 3u);
    for (const config::LightConfig& light : run.config.lights) {
        ASSERT_NE(light.shadow.param("resolution"), nullptr) << light.name;
        EXPECT_EQ(*light.shadow.param("resolution"), 512) << light.name;
        EXPECT_EQ(light.shadow.params[0].where, "--set hard.resolution");
    }
    EXPECT_EQ(run.config.width, 32u);
    EXPECT_EQ(run.config.height, 24u);
    EXPECT_EQ(run.config.frames, 3u);
    EXPECT_EQ(run.config.culling, config::CullingMode::ReceiverMask);
    EXPECT_EQ(run.rest.lights.size(), 3u);
    EXPECT_FALSE(run.scene.instances.empty());

    // An override that no light uses is an error, unless the run takes only the overrides
    // of the techniques it uses (a sweep variant's share).
    options.overrides = config::parseParamOverrides({"pcss.light_size=1"});
    try {
        config::prepareRun(kConfigs / "gltf_scene_lights.json", options);
        ADD_FAILURE() << "expected ConfigError";
    } catch (const ConfigError& e) {
        EXPECT_TRUE(has(e.what(), "--set pcss.light_size: no light of")) << e.what();
    }
    options.overridesOfUsedTechniquesOnly = true;
    EXPECT_EQ(config::prepareRun(kConfigs / "gltf_scene_lights.json", options).config.lights[0].shadow.params.size(), 0u);
}

TEST(Run, EveryPoseStartsFromTheRestState)
{
    config::PreparedRun run = config::prepareRun(penumbra::test::sourceDir() / "config/animated.json", {});
    const glm::vec3 restCamera = run.rest.camera.position;
    EXPECT_EQ(run.config.camera.position, restCamera) << "unposed until poseAt";
    EXPECT_EQ(run.poseAt(1.0f).size(), 1u);  // the sphere moved
    EXPECT_FLOAT_EQ(run.config.camera.position.x, -4.0f);
    run.poseAtFrame(0);
    EXPECT_FLOAT_EQ(run.config.camera.position.x, 15.0f);
    EXPECT_EQ(run.rest.camera.position, restCamera);
}

TEST(Config, SchemaKeyIsForEditors)
{
    // The README's advice: "$schema" lets an editor validate and complete a config.
    json doc = minimal();
    doc["$schema"] = "schema/penumbra-config.schema.json";
    EXPECT_EQ(config::parseConfig(doc, "scene.json").lights.size(), 1u);
    doc["$schema"] = 3;
    EXPECT_TRUE(has(errorOf(doc), "scene.json: /$schema: must be the JSON Schema's path or URL (a string), got 3"))
        << errorOf(doc);
}

namespace {

// minimal() lit by a sun along (0, -1, 0) with `tracks` as its animation.
json withSun(const char* tracks)
{
    json doc = minimal();
    doc["lights"] = json::parse(R"([{"type": "directional", "direction": [0, -1, 0]},
        {"type": "spot", "position": [0, 10, 0], "direction": [0, -1, 0]},
        {"type": "point", "position": [0, 5, 0]},
        {"type": "rect", "position": [0, 5, 0], "target": [0, 0, 0], "size": [2, 1], "tangent": [1, 0, 0]}])");
    doc["animation"] = json::parse(fmt::format(R"({{"tracks": {}}})", tracks));
    return doc;
}

// withSun(tracks) posed at `timeS`.
config::RenderConfig posedAt(const char* tracks, float timeS)
{
    config::RenderConfig c = config::parseConfig(withSun(tracks), "scene.json");
    scene::Scene s;
    config::applyAnimation(c.animation, timeS, c, s);
    return c;
}

} // namespace

TEST(Animation, TurnsASunsDirection)
{
    const config::RenderConfig c =
        posedAt(R"([{"target": "/lights/0/direction", "keys": [{"t": 0, "value": [0, -2, 0]}, {"t": 1, "value": [2, -2, 0]}]}])", 0.5f);
    const glm::vec3 d = c.lights[0].light.direction;
    EXPECT_NEAR(glm::length(d), 1.0f, 1e-6f);  // normalised when applied
    EXPECT_NEAR(d.x, 1.0f / std::sqrt(5.0f), 1e-6f);
    EXPECT_NEAR(d.y, -2.0f / std::sqrt(5.0f), 1e-6f);
}

TEST(Animation, DirectionKeysCannotPassThroughZero)
{
    const auto error = [](const char* tracks) { return errorOf(withSun(tracks)); };
    EXPECT_TRUE(has(error(R"([{"target": "/lights/0/direction", "keys": [{"t": 0, "value": [0, -1, 0]}, {"t": 1, "value": [0, 0, 0]}]}])"),
                    "scene.json: /animation/tracks/0/keys/1/value: a direction must be non-zero"));
    EXPECT_TRUE(has(error(R"([{"target": "/lights/1/direction", "interpolation": "smooth",
                               "keys": [{"t": 0, "value": [0, -1, 1]}, {"t": 1, "value": [0, 2, -2]}]}])"),
                    "scene.json: /animation/tracks/0/keys/1/value: points opposite to key 0: the direction would pass "
                    "through zero between them; add a key in between"));
    // A stepped track jumps from one key to the next: opposite keys are fine.
    EXPECT_NO_THROW(config::parseConfig(withSun(R"([{"target": "/lights/0/direction", "interpolation": "step",
        "keys": [{"t": 0, "value": [1, -1, 0]}, {"t": 1, "value": [-1, 1, 0]}]}])"), "scene.json"));

    // A curve that comes through zero anyway (here, keys that were never validated) keeps
    // the direction the light had.
    config::RenderConfig c = config::parseConfig(minimal(), "scene.json");
    const glm::vec3 before = c.lights[0].light.direction;
    config::Animation animation;
    animation.tracks.push_back({"/lights/0/direction", config::Interpolation::Linear,
                                {{0.0f, {1.0f, 0.0f, 0.0f}}, {1.0f, {-1.0f, 0.0f, 0.0f}}}});
    scene::Scene s;
    config::applyAnimation(animation, 0.5f, c, s);
    EXPECT_EQ(c.lights[0].light.direction, before);
}

TEST(Animation, TracksOnlyWhatTheLightHas)
{
    const std::vector<std::pair<const char*, const char*>> cases = {
        // A sun has no position: neither its position nor a target can be animated.
        {R"([{"target": "/lights/0/target", "keys": [{"t": 0, "value": [0, 0, 0]}]}])",
         "/animation/tracks/0/target: \"/lights/0/target\" cannot be animated: a directional light has no position, it "
         "shines along its direction; animate /lights/0/direction"},
        {R"([{"target": "/lights/0/position", "keys": [{"t": 0, "value": [0, 9, 0]}]}])",
         "/animation/tracks/0/target: \"/lights/0/position\" cannot be animated: a directional light has no position"},
        {R"([{"target": "/lights/2/direction", "keys": [{"t": 0, "value": [0, -1, 0]}]}])",
         "/animation/tracks/0/target: \"/lights/2/direction\" cannot be animated: a point light shines every way"},
        // A light aimed at a target takes its direction from it.
        {R"([{"target": "/lights/3/direction", "keys": [{"t": 0, "value": [0, -1, 0]}]}])",
         "/animation/tracks/0/target: \"/lights/3/direction\" cannot be animated: light 3 is aimed at its \"target\", "
         "which sets its direction; animate /lights/3/target, or give the light a \"direction\""},
        {R"([{"target": "/lights/1/target", "keys": [{"t": 0, "value": [1, 0, 0]}]},
             {"target": "/lights/1/direction", "keys": [{"t": 0, "value": [0, -1, 0]}]}])",
         "/animation/tracks/1/target: \"/lights/1/direction\" cannot be animated: /animation/tracks/0 animates "
         "\"/lights/1/target\"; a light follows either a target or a direction"},
        {R"([{"target": "/lights/1/colour", "keys": [{"t": 0, "value": [1, 0, 0]}]}])",
         "/animation/tracks/0/target: unknown target \"/lights/1/colour\": a light's animatable values are position, "
         "target, direction, intensity and color"},
    };
    for (const auto& [tracks, message] : cases) {
        const std::string what = errorOf(withSun(tracks));
        EXPECT_TRUE(has(what, message)) << tracks << "\n  got: " << what;
    }
    // A sun aimed at a target in the config: the same reason, at the light's own path.
    json doc = minimal();
    doc["lights"] = json::parse(R"([{"type": "directional", "target": [0, 0, 0]}])");
    EXPECT_TRUE(has(errorOf(doc), "scene.json: /lights/0/target: a directional light has no position to aim from: give "
                                  "its \"direction\" (the way its light travels) instead"))
        << errorOf(doc);
}

TEST(Animation, ARectLightsWidthAxisTurnsWithIt)
{
    const config::RenderConfig c =
        posedAt(R"([{"target": "/lights/3/target", "keys": [{"t": 0, "value": [0, 0, 0]}, {"t": 1, "value": [9, 5, 0]}]}])", 1.0f);
    const scene::Light& rect = c.lights[3].light;
    EXPECT_NEAR(rect.direction.x, 1.0f, 1e-6f);  // now facing +x, where its width axis was
    EXPECT_NEAR(glm::dot(rect.tangent, rect.direction), 0.0f, 1e-6f);
    EXPECT_NEAR(glm::length(rect.tangent), 1.0f, 1e-6f);
}
