// Plugins inside a rendered frame: what a technique's pass writes is what the engine
// reads back as V_l, and a technique that fails (to load, to create, to register) leaves
// its light unshadowed with a warning - or stops the frame when the config requires it -
// while the other lights keep their techniques.
#include "TestConfigs.h"
#include "TestContext.h"
#include "TestPaths.h"  // support/: the build tree's paths

#include "penumbra/config/Config.h"
#include "penumbra/frame/FrameRenderer.h"
#include "penumbra/plugin/PluginRegistry.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

using namespace penumbra;

namespace {

// The test plugins first, then the build tree's (hard).
std::vector<std::filesystem::path> searchPath()
{
    std::vector<std::filesystem::path> path{penumbra::test::testPluginDir()};
    for (const auto& dir : plugin::defaultPluginSearchPath()) path.push_back(dir);
    return path;
}

// Equal up to V_l's storage (R16_UNORM, shaders/common/visibility.glsl): within half a
// step of 1/65535 (0 and 1 are exact).
::testing::AssertionResult allEqual(const std::vector<float>& values, float expected)
{
    const auto bad = std::find_if(values.begin(), values.end(),
                                  [&](float v) { return !(std::abs(v - expected) <= 0.5f / 65535.0f); });
    if (values.empty()) return ::testing::AssertionFailure() << "no values";
    if (bad == values.end()) return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure() << "pixel " << (bad - values.begin()) << " is " << *bad << ", expected "
                                         << expected;
}

bool hasPass(const graph::CompiledGraph& compiled, const std::string& name)
{
    return std::any_of(compiled.passes.begin(), compiled.passes.end(), [&](const auto& p) { return p.name == name; });
}

class FramePlugins : public test::GpuTest {
protected:
    FramePlugins() : registry(searchPath()) {}

    // The default scene at 64 x 36 with two lights: light 0 uses `technique` with
    // `params`, light 1 the test plugin's clear to 0.25.
    config::RenderConfig twoLights(const std::string& technique, const nlohmann::json& params, bool required = false)
    {
        config::RenderConfig cfg = test::defaultTestConfig();
        cfg.width = 64;
        cfg.height = 36;
        cfg.lights.push_back(cfg.lights[0]);
        cfg.lights[0].shadow = {};
        cfg.lights[0].shadow.technique = technique;
        cfg.lights[0].shadow.required = required;
        for (const auto& [name, value] : params.items()) cfg.lights[0].shadow.setParam(name, value, "test");
        cfg.lights[1].shadow = {};
        cfg.lights[1].shadow.technique = "testgood";
        cfg.lights[1].shadow.setParam("fill", 0.25, "test");
        return cfg;
    }

    plugin::PluginRegistry registry;
};

TEST_F(FramePlugins, WhatTheTechniquesPassWritesIsTheLightsVisibility)
{
    const config::RenderConfig cfg = twoLights("testgood", {{"fill", 0.75}});
    const scene::Scene scene = config::buildScene(cfg.scene);
    frame::FrameRenderer renderer(*context, scene, cfg, registry);
    renderer.renderFrame();
    EXPECT_TRUE(renderer.warnings().empty());
    EXPECT_EQ(renderer.techniqueName(0), "testgood");
    EXPECT_TRUE(allEqual(renderer.readVisibility(0), 0.75f));
    EXPECT_TRUE(allEqual(renderer.readVisibility(1), 0.25f));
    const graph::CompiledGraph& compiled = renderer.compiledGraph();
    EXPECT_TRUE(hasPass(compiled, "light0.testgood.fill"));
    EXPECT_TRUE(hasPass(compiled, "light1.testgood.fill"));
}

TEST_F(FramePlugins, AnEnumParameterChangesWhatThePassWrites)
{
    const config::RenderConfig cfg = twoLights("testgood", {{"fill", 0.75}, {"mode", "unshadowed"}});
    const scene::Scene scene = config::buildScene(cfg.scene);
    frame::FrameRenderer renderer(*context, scene, cfg, registry);
    renderer.renderFrame();
    EXPECT_TRUE(allEqual(renderer.readVisibility(0), 1.0f));
}

// plugins/example is hard's default variant (one nearest compare, depth bias 4, slope
// bias 2) written as briefly as the SDK allows, on the engine's render::ShadowMap: the
// same V as hard for every light type, the cube atlas of point and area lights included.
TEST_F(FramePlugins, TheExamplePluginShadowsEveryLightTypeAsHardDoes)
{
    for (const scene::LightType type :
         {scene::LightType::Directional, scene::LightType::Spot, scene::LightType::Point, scene::LightType::Rect}) {
        SCOPED_TRACE(scene::lightTypeName(type));
        config::RenderConfig cfg = test::defaultTestConfig();
        cfg.width = 160;
        cfg.height = 90;
        test::setLightType(cfg.lights[0], type);
        const scene::Scene scene = config::buildScene(cfg.scene);
        std::vector<float> visibility[2];
        for (const int i : {0, 1}) {
            cfg.lights[0].shadow = {};
            cfg.lights[0].shadow.technique = i == 0 ? "example" : "hard";
            cfg.lights[0].shadow.required = true;
            cfg.lights[0].shadow.setParam("resolution", 512, "test");
            frame::FrameRenderer renderer(*context, scene, cfg, registry);
            renderer.renderFrame();
            visibility[i] = renderer.readVisibility(0);
        }
        ASSERT_EQ(visibility[0].size(), visibility[1].size());
        float worst = 0.0f;
        size_t shadowed = 0;
        for (size_t p = 0; p < visibility[0].size(); ++p) {
            worst = std::max(worst, std::abs(visibility[0][p] - visibility[1][p]));
            shadowed += visibility[1][p] < 0.5f ? 1 : 0;
        }
        EXPECT_LE(worst, 1e-6f);
        EXPECT_GT(shadowed, 200u) << "too few shadowed pixels for the comparison to mean anything";
    }
}

// Technique "none": an unshadowed light by choice. No plugin, no pass, no V_l, no
// warning; shading takes V = 1, so the frame is the one a technique writing 1 gives.
TEST_F(FramePlugins, TechniqueNoneLeavesTheLightUnshadowedWithoutPassesOrImage)
{
    config::RenderConfig none = twoLights("testgood", {});
    none.lights[0].shadow = {};
    none.lights[0].shadow.technique = "none";
    const scene::Scene scene = config::buildScene(none.scene);
    frame::FrameRenderer renderer(*context, scene, none, registry);
    renderer.renderFrame();
    EXPECT_TRUE(renderer.warnings().empty());
    EXPECT_EQ(renderer.techniqueName(0), "none");
    EXPECT_TRUE(allEqual(renderer.readVisibility(0), 1.0f));
    EXPECT_TRUE(allEqual(renderer.readVisibility(1), 0.25f));
    const graph::CompiledGraph& compiled = renderer.compiledGraph();
    for (const auto& p : compiled.passes) EXPECT_NE(p.name.rfind("light0", 0), 0u) << p.name;
    for (const auto& r : compiled.resources) EXPECT_NE(r.name, "light0.visibility");

    const config::RenderConfig lit = twoLights("testgood", {{"mode", "unshadowed"}});
    frame::FrameRenderer litRenderer(*context, scene, lit, registry);
    litRenderer.renderFrame();
    EXPECT_EQ(renderer.readColor(), litRenderer.readColor()) << "V = 1 in shading, as a technique writing 1 gives";
}

// Each way a light's technique can fail: the light is unshadowed (V = 1, the contract's
// neutral value) and a warning names light, plugin and cause; the other light is intact.
TEST_F(FramePlugins, AFailingTechniqueLeavesItsLightUnshadowedAndTheOthersIntact)
{
    struct Case {
        std::string technique;
        nlohmann::json params;
        std::string warning;
    };
    const std::vector<Case> cases = {
        {"nosuch", nlohmann::json::object(), "plugin 'nosuch': no file penumbra-nosuch.so on the plugin search path"},
        {"nodep", nlohmann::json::object(), "libpenumbra_test_absent.so: cannot open shared object file"},
        {"throws", nlohmann::json::object(), "exception during registration: shader throws/visibility.comp: not found"},
        {"throws", {{"behaviour", "return_null"}}, "the plugin's factory returned no technique"},
        {"testgood", {{"enabled", false}}, "registered no pass that writes 'light0.visibility'"},
    };
    for (const Case& c : cases) {
        SCOPED_TRACE(c.technique + " " + c.params.dump());
        const config::RenderConfig cfg = twoLights(c.technique, c.params);
        const scene::Scene scene = config::buildScene(cfg.scene);
        frame::FrameRenderer renderer(*context, scene, cfg, registry);
        renderer.renderFrame();
        ASSERT_EQ(renderer.warnings().size(), 1u);
        const std::string& warning = renderer.warnings()[0];
        EXPECT_EQ(warning.rfind("light 0: rendered without shadows: ", 0), 0u) << warning;
        EXPECT_NE(warning.find(c.warning), std::string::npos) << warning;
        EXPECT_EQ(renderer.techniqueName(0), "");
        EXPECT_TRUE(allEqual(renderer.readVisibility(0), 1.0f));
        EXPECT_TRUE(allEqual(renderer.readVisibility(1), 0.25f));
        // Lit unshadowed: no pass of its own, not even a clear (V reads as 1).
        for (const auto& pass : renderer.compiledGraph().passes)
            EXPECT_NE(pass.name.rfind("light0.", 0), 0u) << pass.name;
    }
}

TEST_F(FramePlugins, ARequiredTechniqueThatFailsStopsTheFrame)
{
    const std::vector<std::pair<std::string, nlohmann::json>> cases = {
        {"nodep", nlohmann::json::object()}, {"throws", nlohmann::json::object()}, {"testgood", {{"enabled", false}}}};
    for (const auto& [technique, params] : cases) {
        SCOPED_TRACE(technique);
        const config::RenderConfig cfg = twoLights(technique, params, true);
        const scene::Scene scene = config::buildScene(cfg.scene);
        try {
            frame::FrameRenderer renderer(*context, scene, cfg, registry);
            ADD_FAILURE() << "the frame was built";
        } catch (const plugin::PluginError& e) {
            EXPECT_NE(std::string(e.what()).find(technique), std::string::npos) << e.what();
        }
    }
    // The registry survives: the next frame loads and renders.
    const config::RenderConfig cfg = twoLights("testgood", {{"fill", 0.5}}, true);
    const scene::Scene scene = config::buildScene(cfg.scene);
    frame::FrameRenderer renderer(*context, scene, cfg, registry);
    renderer.renderFrame();
    EXPECT_TRUE(allEqual(renderer.readVisibility(0), 0.5f));
}

} // namespace
