// Edits over one long-lived scene (frame::SceneResources): a renderer built for an edited
// config over the resources of the one before keeps the technique instances of the lights
// the edit did not touch, creates the others, and draws - bit for bit - the image of a
// fresh start with the edited config (its own resources, no technique kept). Each kind of
// edit has a test; the technique sweep puts every technique plugin beside a light that
// the edit changes.
#include "PluginFrame.h"
#include "TestConfigs.h"
#include "TestContext.h"

#include "penumbra/config/Config.h"
#include "penumbra/frame/FrameRenderer.h"
#include "penumbra/frame/SceneResources.h"
#include "penumbra/plugin/PluginRegistry.h"

#include <gtest/gtest.h>

#include <cstring>
#include <memory>
#include <set>
#include <string>
#include <vector>

using namespace penumbra;

namespace {

// What a frame shows: the colour image and every light's V, as read back.
struct Drawn {
    std::vector<uint8_t> color;
    std::vector<std::vector<float>> visibility;
};

Drawn draw(frame::FrameRenderer& renderer)
{
    renderer.renderFrame();
    Drawn d{renderer.readColor(), {}};
    for (size_t l = 0; l < renderer.lightCount(); ++l) d.visibility.push_back(renderer.readVisibility(l));
    return d;
}

// Bit for bit (floats compared by their bytes: a NaN would differ from itself).
::testing::AssertionResult sameImages(const Drawn& edited, const Drawn& fresh)
{
    if (edited.color != fresh.color) return ::testing::AssertionFailure() << "the colour images differ";
    if (edited.visibility.size() != fresh.visibility.size()) return ::testing::AssertionFailure() << "light counts differ";
    for (size_t l = 0; l < fresh.visibility.size(); ++l) {
        const std::vector<float>& a = edited.visibility[l];
        const std::vector<float>& b = fresh.visibility[l];
        if (a.size() != b.size() || std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) != 0) {
            size_t first = 0;
            while (first < std::min(a.size(), b.size()) && std::memcmp(&a[first], &b[first], sizeof(float)) == 0) ++first;
            return ::testing::AssertionFailure() << "light " << l << "'s V differs first at pixel " << first;
        }
    }
    return ::testing::AssertionSuccess();
}

// Another valid value of the plugin's first parameter (a Bool flipped, an Enum's next
// choice, an Int or Float moved inside its range), or null for a plugin without any.
nlohmann::json otherValue(const plugin::LoadedPlugin& plugin, std::string& name)
{
    for (uint32_t i = 0; i < plugin.info->paramCount; ++i) {
        const plugin::ParamSpec& p = plugin.info->params[i];
        name = p.name;
        switch (p.type) {
        case plugin::ParamType::Bool: return p.defaultValue == 0.0;
        case plugin::ParamType::Enum: return p.choices[(uint32_t(p.defaultValue) + 1) % p.choiceCount];
        case plugin::ParamType::Int: {
            const int step = p.odd ? 2 : 1;
            const int v = int(p.defaultValue) + step <= int(p.maxValue) ? int(p.defaultValue) + step : int(p.defaultValue) - step;
            return v;
        }
        case plugin::ParamType::Float:
            return p.defaultValue < p.maxValue ? (p.defaultValue + p.maxValue) / 2.0 : (p.defaultValue + p.minValue) / 2.0;
        }
    }
    return nullptr;
}

class SceneEdits : public test::GpuTest {
protected:
    void SetUp() override
    {
        GpuTest::SetUp();
        registry = std::make_unique<plugin::PluginRegistry>();
        base = test::defaultTestConfig();
        base.width = 48;
        base.height = 32;
        base.lights.push_back(base.lights[0]);
        test::setLightType(base.lights[1], scene::LightType::Directional);
        test::setShadow(base.lights[0], "hard", {});
        test::setShadow(base.lights[1], "pcss", {});
        scene = config::buildScene(base);
        resources = std::make_shared<frame::SceneResources>(*context, scene, frame::SceneResources::batchingOf(base));
    }
    void TearDown() override
    {
        resources.reset();
        registry.reset();
        GpuTest::TearDown();
    }

    // `edited` drawn by a renderer built over the first one's resources after it drew
    // `before`, and by a fresh one; returns the edited renderer for its figures.
    std::unique_ptr<frame::FrameRenderer> expectEditDrawsAsAFreshStart(const config::RenderConfig& before,
                                                                      const config::RenderConfig& edited,
                                                                      const std::string& label)
    {
        auto first = std::make_unique<frame::FrameRenderer>(resources, before, *registry);
        first->renderFrame();
        auto next = std::make_unique<frame::FrameRenderer>(resources, edited, *registry, first.get());
        const Drawn afterEdit = draw(*next);
        frame::FrameRenderer fresh(*context, scene, edited, *registry);
        EXPECT_TRUE(sameImages(afterEdit, draw(fresh))) << label;
        return next;
    }

    std::unique_ptr<plugin::PluginRegistry> registry;
    config::RenderConfig base;
    scene::Scene scene;
    std::shared_ptr<frame::SceneResources> resources;
};

TEST_F(SceneEdits, AParameterOfOneLightRecreatesItsTechniqueAlone)
{
    config::RenderConfig edited = base;
    edited.lights[1].shadow.setParam("filter_samples", 16, "test");
    const auto renderer = expectEditDrawsAsAFreshStart(base, edited, "pcss parameter");
    EXPECT_TRUE(renderer->techniqueKept(0));
    EXPECT_FALSE(renderer->techniqueKept(1));
    // The scene was uploaded, its BVH built and each shading pipeline (one per set of
    // lights that a rectangle of the screen adds) made once for both, as was the fill of
    // V beyond a light's rectangle (LightPassIo::fillOutside).
    EXPECT_EQ(resources->visibilityBuilds(), 1u);
    EXPECT_EQ(resources->bvhBuilds(), 1u);
    std::set<uint32_t> variants;
    for (const auto& region : renderer->shadingRegions()) variants.insert(region.shaded);
    EXPECT_GE(variants.size(), 1u);
    EXPECT_EQ(resources->pipelinesMade(), variants.size() + 1);
}

TEST_F(SceneEdits, ATechniqueSwitchRecreatesThatLightAlone)
{
    for (const char* technique : {"vsm", "none", "example"}) {
        config::RenderConfig edited = base;
        test::setShadow(edited.lights[1], technique, {});
        const auto renderer = expectEditDrawsAsAFreshStart(base, edited, technique);
        EXPECT_TRUE(renderer->techniqueKept(0)) << technique;
        EXPECT_FALSE(renderer->techniqueKept(1)) << technique;
    }
}

TEST_F(SceneEdits, ALightsShapeRecreatesItsTechniqueAndItsPoseKeepsIt)
{
    config::RenderConfig shaped = base;
    shaped.lights[0].light.outerConeDeg *= 0.8f;
    shaped.lights[0].light.innerConeDeg *= 0.8f;
    EXPECT_FALSE(expectEditDrawsAsAFreshStart(base, shaped, "spot cone")->techniqueKept(0));

    for (const float dx : {0.5f, -2.0f}) {
        config::RenderConfig moved = base;
        moved.lights[0].light.position.x += dx;
        moved.lights[1].light.intensity *= 2.0f;
        const auto renderer = expectEditDrawsAsAFreshStart(base, moved, "light moved");
        EXPECT_TRUE(renderer->techniqueKept(0));
        EXPECT_TRUE(renderer->techniqueKept(1));
    }
}

TEST_F(SceneEdits, TheOutputSizeAndTheCullingRecreateEveryTechniqueOverTheSameScene)
{
    config::RenderConfig resized = base;
    resized.width = 40;
    resized.height = 40;
    auto renderer = expectEditDrawsAsAFreshStart(base, resized, "size");
    EXPECT_FALSE(renderer->techniqueKept(0));
    EXPECT_FALSE(renderer->techniqueKept(1));

    for (const config::CullingMode mode : {config::CullingMode::Frustum, config::CullingMode::ReceiverMask}) {
        config::RenderConfig culled = base;
        culled.culling = mode;
        renderer = expectEditDrawsAsAFreshStart(base, culled, config::cullingModeName(mode));
        EXPECT_FALSE(renderer->techniqueKept(0));
    }
    // A visibility service per output and culling; the scene's upload and BVH are shared.
    EXPECT_EQ(resources->visibilityBuilds(), 6u);
    EXPECT_EQ(resources->bvhBuilds(), 1u);
}

TEST_F(SceneEdits, AddingALightKeepsTheOthersAndRemovingOneRecreatesTheLightsAfterIt)
{
    config::RenderConfig added = base;
    added.lights.push_back(base.lights[0]);
    test::setLightType(added.lights[2], scene::LightType::Point);
    auto renderer = expectEditDrawsAsAFreshStart(base, added, "light added");
    EXPECT_TRUE(renderer->techniqueKept(0));
    EXPECT_TRUE(renderer->techniqueKept(1));
    EXPECT_FALSE(renderer->techniqueKept(2));

    config::RenderConfig removed = base;
    removed.lights.erase(removed.lights.begin());
    renderer = expectEditDrawsAsAFreshStart(base, removed, "light 0 removed");
    EXPECT_FALSE(renderer->techniqueKept(0));  // was light 1: its names and index change
}

TEST_F(SceneEdits, ACameraMoveAndAnotherDebugImageKeepEveryTechnique)
{
    frame::FrameRenderer first(resources, base, *registry);
    first.renderFrame();
    config::RenderConfig moved = base;
    moved.camera.position += glm::vec3(0.5f, 0.25f, 0.0f);
    frame::FrameRenderer next(resources, moved, *registry, &first);
    next.requestImage("light0.hard.shadow_map");
    const Drawn afterEdit = draw(next);
    EXPECT_TRUE(next.techniqueKept(0));
    EXPECT_TRUE(next.techniqueKept(1));
    frame::FrameRenderer fresh(*context, scene, moved, *registry);
    fresh.requestImage("light0.hard.shadow_map");
    EXPECT_TRUE(sameImages(afterEdit, draw(fresh)));
    EXPECT_EQ(next.readImage("light0.hard.shadow_map").values, fresh.readImage("light0.hard.shadow_map").values);
}

TEST_F(SceneEdits, ARendererWhoseTechniquesAnotherDeclaredDrawsItsOwnFrameAgain)
{
    // The viewer keeps the last renderer when an edit fails to draw: the techniques the
    // failed one shared must come back to the old one's graph and lights.
    frame::FrameRenderer first(resources, base, *registry);
    const Drawn before = draw(first);
    config::RenderConfig edited = base;
    edited.lights[0].light.position.x += 1.0f;
    edited.lights[1].shadow.setParam("filter_samples", 8, "test");
    {
        frame::FrameRenderer next(resources, edited, *registry, &first);
        next.renderFrame();
        ASSERT_TRUE(next.techniqueKept(0));
    }
    EXPECT_TRUE(sameImages(draw(first), before));
}

// Every technique plugin beside a light whose parameter the edit changes: the technique
// keeps its instance (and what it grew) and draws what a fresh start draws; then an edit
// of its own first parameter recreates it alone.
class SceneEditsPerTechnique : public SceneEdits, public ::testing::WithParamInterface<const char*> {};

TEST_P(SceneEditsPerTechnique, KeptAcrossTheOtherLightsEditAndRecreatedForItsOwn)
{
    const std::string technique = GetParam();
    config::RenderConfig before = base;
    // An adaptive shadow map without its time budget: the tiles a frame adds then depend
    // on the view alone, not on the machine's load, so that both starts settle alike.
    test::setShadow(before.lights[0], technique,
                    technique == "adaptive-sm" ? nlohmann::json{{"refine_ms", 1e5}} : nlohmann::json::object());
    config::RenderConfig other = before;
    other.lights[1].shadow.setParam("filter_samples", 16, "test");
    auto renderer = expectEditDrawsAsAFreshStart(before, other, technique + ": the other light's parameter");
    EXPECT_TRUE(renderer->techniqueKept(0)) << technique;
    EXPECT_FALSE(renderer->techniqueKept(1)) << technique;

    std::string name;
    const nlohmann::json value = otherValue(registry->load(technique), name);
    if (value.is_null()) return;
    config::RenderConfig own = before;
    own.lights[0].shadow.setParam(name, value, "test");
    renderer = expectEditDrawsAsAFreshStart(before, own, technique + ": its own " + name);
    EXPECT_FALSE(renderer->techniqueKept(0)) << technique;
    EXPECT_TRUE(renderer->techniqueKept(1)) << technique;
}

INSTANTIATE_TEST_SUITE_P(Techniques, SceneEditsPerTechnique,
                         ::testing::Values("hard", "pcss", "vsm", "vssm", "backprojection", "deep", "adaptive-sm",
                                           "reference", "example"),
                         [](const ::testing::TestParamInfo<const char*>& info) {
                             std::string name = info.param;
                             for (char& c : name) c = c == '-' ? '_' : c;
                             return name;
                         });

} // namespace
