// Issue 43: a 1 MB string became 1 MB of stderr. Every message of the config reader, the
// technique parameters and --set shows a value the user gave shortened (core::shortJson,
// core::shortText) and still names where it is: one table of configs, each with a huge
// string or array at one place, read as `validate` reads them.
#include "ScratchFolder.h"
#include "TestConfigs.h"

#include "penumbra/config/Config.h"
#include "penumbra/config/Document.h"
#include "penumbra/config/Overrides.h"
#include "penumbra/config/Run.h"
#include "penumbra/core/Error.h"
#include "penumbra/plugin/Params.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

using namespace penumbra;
using nlohmann::json;
namespace fs = std::filesystem;

namespace {

// A message naming the place and what was expected stays within this, whatever the value.
constexpr size_t kMaxMessageBytes = 2000;

const std::string& megabyteString()
{
    static const std::string s(1 << 20, 'x');
    return s;
}

const json& hugeArray()
{
    static const json a = [] {
        json out = json::array();
        for (int i = 0; i < 200000; ++i) out.push_back(i);
        return out;
    }();
    return a;
}

json baseConfig()
{
    return json::parse(R"({"camera": {"position": [0, 5, 10], "target": [0, 0, 0]},
                           "lights": [{"type": "spot", "position": [0, 10, 0], "target": [0, 0, 0]}]})");
}

struct LongValueCase {
    const char* name;
    std::string where;  // what the message must name: a JSON path, a flag
    json config;        // the config, with the long value in it
    bool buildScene = false;  // the value is checked when the scene is built (prepareRun)
};

std::vector<LongValueCase> longValueCases()
{
    const std::string& s = megabyteString();
    const json& a = hugeArray();
    std::vector<LongValueCase> cases;
    const auto at = [&](const char* name, const std::string& pointer, const json& value, std::string where = "") {
        json c = baseConfig();
        c[json::json_pointer(pointer)] = value;
        cases.push_back({name, where.empty() ? pointer : where, std::move(c)});
    };
    at("technique string", "/lights/0/shadow/technique", s);
    at("technique array", "/lights/0/shadow/technique", a);
    at("required", "/lights/0/shadow/required", s);
    at("light type", "/lights/0/type", s);
    at("light name", "/lights/0/name", a);
    at("intensity string", "/lights/0/intensity", s);
    at("intensity array", "/lights/0/intensity", a);
    at("position", "/lights/0/position", a);
    at("camera fov", "/camera/fov_y_deg", s);
    at("camera target", "/camera/target", s);
    at("output width", "/output/width", s);
    at("culling", "/culling", s);
    at("draw batching", "/draw_batching", a);
    at("shadow focus", "/shadow_focus", s);
    at("schema", "/$schema", a);
    at("notes", "/notes", s);
    at("a note", "/notes", json::array({a}), "/notes/0");
    at("include array", "/include", a);
    at("include path", "/include", s, "/include");
    at("scene generator", "/scene/generator", s);
    at("scene gltf", "/scene/gltf", s);
    at("generator parameter", "/scene/params/strands", a);
    at("animation target", "/animation/tracks",
       json::array({{{"target", "/lights/" + s}, {"keys", json::array({{{"t", 0}, {"value", 1}}})}}}),
       "/animation/tracks/0/target");
    at("animation key", "/animation/tracks",
       json::array({{{"target", "/camera/fov_y_deg"}, {"keys", json::array({{{"t", 0}, {"value", s}}})}}}),
       "/animation/tracks/0/keys/0/value");
    at("sweep value", "/sweep", json::array({{{"path", "/lights/0/intensity"}, {"values", json::array({s})}}}),
       "/lights/0/intensity");
    at("sweep values of several paths", "/sweep",
       json::array({{{"paths", {"/lights/0/intensity", "/camera/fov_y_deg"}}, {"values", json::array({a})}}}),
       "/sweep/0/values/0");
    at("sweep path", "/sweep", json::array({{{"path", s}, {"values", {1}}}}), "/sweep/0/path");
    at("sweep label", "/sweep", json::array({{{"path", "/lights/0/intensity"}, {"values", {1}}, {"labels", {a}}}}),
       "/sweep/0/labels/0");
    {
        json c = baseConfig();
        c["lights"][0][s] = 1;  // an unknown key of a million characters
        cases.push_back({"unknown key", "/lights/0/xxxx", std::move(c)});
    }
    {
        json c = baseConfig();
        c["scene"] = {{"generator", "hair"}, {"params", {{"strands", s}}}};
        cases.push_back({"generator parameter text", "strands", std::move(c), true});
    }
    return cases;
}

class LongValues : public test::ScratchFolderTest {
protected:
    // The ConfigError of reading `config` as `validate` does: the document, every sweep
    // variant, and (`buildScene`) the scene.
    std::string errorReading(const json& config, bool buildScene) const
    {
        const fs::path file = dir / "long.json";
        std::ofstream(file, std::ios::binary) << config.dump();
        try {
            const config::ConfigDocument document = config::loadDocument(file);
            test::everyVariant(document);
            if (buildScene) {
                config::RenderConfig parsed = config::parseConfig(document);
                config::buildScene(parsed);
            }
        } catch (const ConfigError& e) {
            return e.what();
        }
        return "(accepted)";
    }

};

TEST_F(LongValues, EveryConfigMessageShowsTheValueShortenedAndNamesThePlace)
{
    for (const LongValueCase& c : longValueCases()) {
        SCOPED_TRACE(c.name);
        const std::string what = errorReading(c.config, c.buildScene);
        EXPECT_LT(what.size(), kMaxMessageBytes) << what.substr(0, 400) << "...";
        EXPECT_NE(what.find(c.where), std::string::npos) << what.substr(0, 400);
    }
}

TEST(LongValueParams, TechniqueParameterMessagesShowValuesAndNamesShortened)
{
    static const plugin::ParamSpec specs[] = {
        {"pcf_kernel", plugin::ParamType::Int, 3, 1, 15, "texels", "filter width"}};
    plugin::ParamValues values("hard", specs, 1);
    const std::string& s = megabyteString();
    const auto error = [&](const std::string& name, const json& value) {
        try {
            values.set(name, value, "a.json: /lights/0/shadow/" + name.substr(0, 20));
        } catch (const ConfigError& e) {
            return std::string(e.what());
        }
        return std::string("(accepted)");
    };
    for (const std::string& what : {error("pcf_kernel", s), error("pcf_kernel", hugeArray()), error(s, 1)}) {
        EXPECT_LT(what.size(), kMaxMessageBytes) << what.substr(0, 400);
        EXPECT_NE(what.find("a.json: /lights/0/shadow/"), std::string::npos) << what.substr(0, 400);
    }
}

TEST(LongValueOverrides, SetMessagesShowTheSettingShortened)
{
    const std::string& s = megabyteString();
    const auto parseError = [](const std::string& setting) {
        try {
            config::parseParamOverride(setting);
        } catch (const ConfigError& e) {
            return std::string(e.what());
        }
        return std::string("(accepted)");
    };
    const std::string malformed = parseError(s);
    EXPECT_LT(malformed.size(), kMaxMessageBytes);
    EXPECT_NE(malformed.find("--set 'xxx"), std::string::npos) << malformed.substr(0, 400);

    // A technique no light uses, of a million characters.
    config::RenderConfig config = test::defaultTestConfig();
    try {
        config::applyParamOverrides(config, {config::parseParamOverride(s + ".pcf_kernel=5")});
        ADD_FAILURE() << "an override of a technique no light uses was accepted";
    } catch (const ConfigError& e) {
        const std::string what = e.what();
        EXPECT_LT(what.size(), kMaxMessageBytes);
        EXPECT_NE(what.find("no light of"), std::string::npos) << what.substr(0, 400);
    }
}

} // namespace
