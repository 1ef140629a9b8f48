#include "penumbra/config/Config.h"
#include "penumbra/core/Error.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <fstream>

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
    const config::RenderConfig c = config::loadConfig(fs::path(PENUMBRA_SOURCE_DIR) / "config/default.json");
    EXPECT_EQ(c.width, 1280u);
    EXPECT_EQ(c.height, 720u);
    ASSERT_EQ(c.lights.size(), 1u);
    EXPECT_EQ(c.lights[0].shadow.resolution, 2048u);
    EXPECT_EQ(c.lights[0].shadow.technique, "hard");
    EXPECT_NEAR(glm::length(c.lights[0].light.direction), 1.0f, 1e-6f);
}

TEST(Config, MinimalConfigGetsDefaults)
{
    const config::RenderConfig c = config::parseConfig(minimal(), "scene.json");
    EXPECT_EQ(c.frames, 1u);
    EXPECT_EQ(c.scene.generator, "box-grid");
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
    doc["lights"][0]["shadow"] = {{"technique", "raytraced"}};
    EXPECT_NE(errorOf(doc).find("/lights/0/shadow/technique: must be one of hard, got \"raytraced\""),
              std::string::npos);
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
    const fs::path file = fs::path(PENUMBRA_TEST_DATA_DIR) / "configs/malformed.json";
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
