// Lights that cannot matter cost nothing (frame/LightInfluence.h): a light that reaches no
// visible receiver gets no passes and adds no light, and the frame is - bit for bit - the
// frame without it; for every light type, for lights entering and leaving the view over
// an animation, and for the lights max_shadowed_lights leaves unshadowed.
#include "PluginFrame.h"
#include "TestConfigs.h"
#include "TestContext.h"

#include "penumbra/config/Config.h"
#include "penumbra/frame/FrameRenderer.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

using namespace penumbra;
using frame::LightFate;

namespace {

struct Frame {
    std::vector<uint8_t> color;
    std::vector<std::string> passes;
};

Frame draw(frame::FrameRenderer& renderer)
{
    const frame::FrameTimings timings = renderer.renderFrame();
    Frame f{renderer.readColor(), {}};
    for (const graph::PassTiming& pass : timings.passes) f.passes.push_back(pass.name);
    return f;
}

bool hasPassOf(const Frame& frame, const std::string& prefix)
{
    return std::any_of(frame.passes.begin(), frame.passes.end(),
                       [&](const std::string& name) { return name.rfind(prefix, 0) == 0; });
}

// The largest difference of one colour channel between two RGBA8 images.
int largestDifference(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b)
{
    int largest = a.size() == b.size() ? 0 : 255;
    for (size_t i = 0; i < std::min(a.size(), b.size()); ++i) largest = std::max(largest, std::abs(int(a[i]) - int(b[i])));
    return largest;
}

// A light of `type` that cannot matter to config/default.json's view: what its influence
// misses is the case each type has.
config::LightConfig lightThatCannotMatter(scene::LightType type)
{
    config::LightConfig light = test::defaultTestConfig().lights[0];
    light.name = "extra";
    test::setLightType(light, type);
    test::setShadow(light, "hard", {});
    switch (type) {
    case scene::LightType::Spot:  // above the scene, its cone pointing up
        light.light.position = {0.0f, 12.0f, 0.0f};
        light.light.direction = glm::normalize(glm::vec3(0.1f, 1.0f, 0.0f));
        break;
    case scene::LightType::Point:  // so far away that its radiance is below the cutoff
        light.light.position = {0.0f, 10.0f, 5e4f};
        light.light.intensity = 10.0f;
        break;
    case scene::LightType::Rect:
    case scene::LightType::Disk:  // above the scene, emitting upwards
        light.light.position = {0.0f, 12.0f, 0.0f};
        light.light.direction = {0.0f, 1.0f, 0.0f};
        break;
    case scene::LightType::Directional:  // switched off
        light.light.intensity = 0.0f;
        break;
    }
    return light;
}

// config/default.json at 96 x 54, with a second copy of its spot light named `name` at
// `position`, aimed at the origin, when `name` is given.
config::RenderConfig smallDefault(const std::string& name = {}, glm::vec3 position = {})
{
    config::RenderConfig config = test::defaultTestConfig();
    config.width = 96;
    config.height = 54;
    if (!name.empty()) {
        config::LightConfig second = config.lights[0];
        second.name = name;
        second.light.position = position;
        second.light.direction = glm::normalize(-position);
        config.lights.push_back(second);
    }
    return config;
}

class LightCulling : public test::GpuTest, public ::testing::WithParamInterface<test::LightCase> {};

} // namespace

TEST_P(LightCulling, ALightThatCannotMatterHasNoPassesAndTheFrameIsTheFrameWithoutIt)
{
    const test::LightCase& c = GetParam();
    config::RenderConfig alone = smallDefault();
    const scene::Scene scene = config::buildScene(alone);
    config::RenderConfig withExtra = alone;
    withExtra.lights.push_back(lightThatCannotMatter(c.type));

    frame::FrameRenderer culled(*context, scene, withExtra, test::plugins());
    const Frame withCulling = draw(culled);
    EXPECT_EQ(culled.lightDecision(1).fate, LightFate::Culled) << c;
    EXPECT_FALSE(culled.lightDecision(1).why.empty());
    EXPECT_EQ(culled.lightDecision(0).fate, LightFate::Shadowed);
    EXPECT_FALSE(hasPassOf(withCulling, "light1.")) << "the culled light's passes ran";
    EXPECT_TRUE(hasPassOf(withCulling, "light0.hard."));
    const std::vector<float> v = culled.readVisibility(1);
    EXPECT_TRUE(std::all_of(v.begin(), v.end(), [](float x) { return x == 1.0f; })) << "a culled light's V is 1";

    frame::FrameRenderer single(*context, scene, alone, test::plugins());
    EXPECT_EQ(withCulling.color, draw(single).color) << c << ": not the frame without the light";

    // Drawn after all (light_culling off), the light adds exactly nothing where its
    // influence is zero (cone, emitting side, zero intensity) and less than a display step
    // where it is beyond its range: the culling never drops a light that shows.
    withExtra.lightCulling = false;
    frame::FrameRenderer drawn(*context, scene, withExtra, test::plugins());
    const Frame withoutCulling = draw(drawn);
    EXPECT_TRUE(hasPassOf(withoutCulling, "light1.hard."));
    if (c.type == scene::LightType::Point) {
        EXPECT_LE(largestDifference(withCulling.color, withoutCulling.color), 1) << c;
    } else {
        EXPECT_EQ(withCulling.color, withoutCulling.color) << c;
    }
}

INSTANTIATE_TEST_SUITE_P(EveryLightType, LightCulling,
                         ::testing::Values(test::LightCase{"spot", scene::LightType::Spot},
                                           test::LightCase{"point", scene::LightType::Point},
                                           test::LightCase{"rect", scene::LightType::Rect},
                                           test::LightCase{"disk", scene::LightType::Disk},
                                           test::LightCase{"directional", scene::LightType::Directional}),
                         [](const auto& info) { return std::string(info.param.name); });

namespace {
class LightCullingFrames : public test::GpuTest {};
}

// A second spot sweeps from the scene up into the sky and back: each frame of the
// renderer that culls equals, bit for bit, the frame of one that draws every light, and
// the light is culled and drawn again as it leaves and re-enters.
TEST_F(LightCullingFrames, ALightLeavingAndEnteringTheViewKeepsEveryFrameExact)
{
    config::RenderConfig config = smallDefault("sweeping", {2.0f, 9.0f, 2.0f});
    test::setShadow(config.lights[1], "pcss", {});
    const scene::Scene scene = config::buildScene(config);
    config::RenderConfig everyLight = config;
    everyLight.lightCulling = false;
    frame::FrameRenderer culled(*context, scene, config, test::plugins());
    frame::FrameRenderer drawn(*context, scene, everyLight, test::plugins());

    std::vector<LightFate> fates;
    const int frames = 9;
    for (int f = 0; f < frames; ++f) {
        // From straight down (0) to 160 degrees (pointing up) at frame 4, then back.
        const float tilt = glm::radians(160.0f * (1.0f - std::abs(float(f - frames / 2)) / float(frames / 2)));
        for (config::RenderConfig* c : {&config, &everyLight})
            c->lights[1].light.direction = {std::sin(tilt), -std::cos(tilt), 0.0f};
        culled.update(config, scene, {});
        drawn.update(everyLight, scene, {});
        const Frame a = draw(culled);
        const Frame b = draw(drawn);
        EXPECT_EQ(a.color, b.color) << "frame " << f;
        fates.push_back(culled.lightDecision(1).fate);
        EXPECT_EQ(hasPassOf(a, "light1."), fates.back() == LightFate::Shadowed) << "frame " << f;
    }
    EXPECT_EQ(fates.front(), LightFate::Shadowed);
    EXPECT_EQ(fates[frames / 2], LightFate::Culled);
    EXPECT_EQ(fates.back(), LightFate::Shadowed);
}

// max_shadowed_lights 1 over two shadowed lights: the one contributing less is lit
// unshadowed - the frame of the same config with its technique "none".
TEST_F(LightCullingFrames, MaxShadowedLightsLightsTheOthersUnshadowed)
{
    config::RenderConfig config = smallDefault("dim", {4.0f, 14.0f, -6.0f});
    config.lights[1].light.intensity *= 0.2f;
    const scene::Scene scene = config::buildScene(config);
    config.maxShadowedLights = 1;
    frame::FrameRenderer ranked(*context, scene, config, test::plugins());
    const Frame a = draw(ranked);
    EXPECT_EQ(ranked.lightDecision(0).fate, LightFate::Shadowed);
    EXPECT_EQ(ranked.lightDecision(1).fate, LightFate::Unshadowed);
    EXPECT_NE(ranked.lightDecision(1).why.find("max_shadowed_lights"), std::string::npos);
    EXPECT_FALSE(hasPassOf(a, "light1."));

    config::RenderConfig none = config;
    none.maxShadowedLights = config::kMaxLights;
    test::setShadow(none.lights[1], "none", {});
    frame::FrameRenderer unshadowed(*context, scene, none, test::plugins());
    EXPECT_EQ(a.color, draw(unshadowed).color);
}

// Only the pixels a light reaches (FrameRenderer::setLightRegions): shading adds each light
// only over its rectangle of the screen, and the frame is, bit for bit, the frame that
// shades every light everywhere; over spots sweeping across and out of the view, a
// narrow spot, lights beside and behind the camera, and every light type.
namespace {

struct RegionCase {
    const char* name;
    scene::LightType type;
    glm::vec3 position;
    glm::vec3 direction;
    float outerConeDeg = 50.0f;
    float intensity = 0.0f;  // 0: the test config's
    bool smallerThanTheScreen = false;  // where the rectangle must leave pixels out
    // Where the pixels it leaves out show surfaces facing away from the light (V 0 there
    // from a pass over the whole screen).
    bool backFacesOutside = false;
};

std::ostream& operator<<(std::ostream& os, const RegionCase& c) { return os << c.name; }

class LightRegions : public test::GpuTest, public ::testing::WithParamInterface<RegionCase> {};

// The small default scene with a second light, of the case's type and placement, under
// hard shadows.
config::RenderConfig regionConfig(const RegionCase& c)
{
    config::RenderConfig config = smallDefault("second", {2.0f, 9.0f, 2.0f});
    config::LightConfig& l = config.lights[1];
    test::setLightType(l, c.type);
    l.light.position = c.position;
    l.light.direction = glm::normalize(c.direction);
    l.light.outerConeDeg = c.outerConeDeg;
    l.light.innerConeDeg = std::min(l.light.innerConeDeg, 0.8f * c.outerConeDeg);
    if (c.intensity > 0.0f) l.light.intensity = c.intensity;
    test::setShadow(l, "hard", {});
    return config;
}

} // namespace

TEST_P(LightRegions, ShadingOnlyTheLightsRectangleGivesTheSameFrame)
{
    const RegionCase& c = GetParam();
    config::RenderConfig config = regionConfig(c);
    const scene::Scene scene = config::buildScene(config);
    frame::FrameRenderer regions(*context, scene, config, test::plugins());
    frame::FrameRenderer everywhere(*context, scene, config, test::plugins());
    everywhere.setLightRegions(false);
    for (frame::FrameRenderer* r : {&regions, &everywhere}) r->setVisibilityReadBack(false);

    for (int f = 0; f < 3; ++f) {  // the camera turns a little each frame
        SCOPED_TRACE(f);
        config.camera.target += glm::vec3(1.5f * float(f), 0.0f, -0.7f * float(f));
        regions.update(config, scene, {});
        everywhere.update(config, scene, {});
        const Frame a = draw(regions);
        const Frame b = draw(everywhere);
        ASSERT_EQ(a.color, b.color) << "largest difference " << largestDifference(a.color, b.color);
        // The regions cover the screen once.
        uint64_t covered = 0, lit = 0;
        for (const auto& region : regions.shadingRegions()) {
            const uint64_t area = uint64_t(region.rect.x1 - region.rect.x0) * uint64_t(region.rect.y1 - region.rect.y0);
            covered += area;
            if ((region.shaded >> 1) & 1u) lit += area;
        }
        EXPECT_EQ(covered, uint64_t(config.width) * config.height);
        ASSERT_EQ(everywhere.shadingRegions().size(), 1u);
        if (c.smallerThanTheScreen) {
            EXPECT_LT(lit, covered) << "the light's rectangle is the whole screen";
        }
    }
}

// Where V is read back (compare, a debug image, the EXR), the technique's visibility pass
// runs over the light's rectangle only (LightPassIo::screenRegion, grown to whole
// workgroups): inside it V is the V of the pass over the whole screen, outside it 1 but
// where the workgroups overhang, and the frame is the same. The pass over the whole
// screen gives 0 outside on surfaces facing away from the light: where the narrow spot's
// rectangle leaves such pixels out, they show it was not computed there.
TEST_P(LightRegions, VisibilityIsComputedOnlyOverTheLightsRectangle)
{
    const RegionCase& c = GetParam();
    config::RenderConfig config = regionConfig(c);
    const scene::Scene scene = config::buildScene(config);
    frame::FrameRenderer regions(*context, scene, config, test::plugins());
    frame::FrameRenderer everywhere(*context, scene, config, test::plugins());
    everywhere.setLightRegions(false);

    size_t leftOut = 0;  // pixels outside the rectangle where the whole-screen pass gives V != 1
    for (int f = 0; f < 3; ++f) {
        SCOPED_TRACE(f);
        config.camera.target += glm::vec3(1.5f * float(f), 0.0f, -0.7f * float(f));
        regions.update(config, scene, {});
        everywhere.update(config, scene, {});
        const Frame a = draw(regions);
        const Frame b = draw(everywhere);
        ASSERT_EQ(a.color, b.color) << "largest difference " << largestDifference(a.color, b.color);
        std::vector<bool> inside(size_t(config.width) * config.height, false);
        for (const auto& region : regions.shadingRegions()) {
            if (!((region.shaded >> 1) & 1u)) continue;
            for (int32_t y = region.rect.y0; y < region.rect.y1; ++y)
                for (int32_t x = region.rect.x0; x < region.rect.x1; ++x) inside[size_t(y) * config.width + size_t(x)] = true;
        }
        const std::vector<float> va = regions.readVisibility(1), vb = everywhere.readVisibility(1);
        ASSERT_EQ(va.size(), inside.size());
        ASSERT_EQ(vb.size(), inside.size());
        for (size_t i = 0; i < inside.size(); ++i) {
            if (inside[i]) {
                ASSERT_EQ(va[i], vb[i]) << "pixel " << i << " inside the rectangle";
            } else {
                // 1, or the pass's value where its last workgroups overhang the rectangle.
                ASSERT_TRUE(va[i] == 1.0f || va[i] == vb[i]) << "pixel " << i << " outside the rectangle: " << va[i];
                leftOut += va[i] == 1.0f && vb[i] != 1.0f;
            }
        }
    }
    if (c.backFacesOutside) {
        EXPECT_GT(leftOut, 0u) << "no pixel shows the pass left the rest of the screen out";
    }
}

INSTANTIATE_TEST_SUITE_P(
    SpotsPointsAndAreas, LightRegions,
    ::testing::Values(RegionCase{"narrow_spot", scene::LightType::Spot, {-3.0f, 8.0f, 1.0f}, {0.2f, -1.0f, 0.1f}, 12.0f,
                                 0.0f, true, true},
                      RegionCase{"spot_at_the_edge", scene::LightType::Spot, {9.0f, 6.0f, 0.0f}, {0.6f, -1.0f, 0.0f}, 25.0f,
                                 0.0f, true},
                      RegionCase{"spot_over_the_camera", scene::LightType::Spot, {0.0f, 9.0f, 14.0f}, {0.0f, -0.5f, -1.0f},
                                 70.0f},
                      RegionCase{"spot_behind_the_camera", scene::LightType::Spot, {0.0f, 4.0f, 30.0f}, {0.0f, -0.1f, -1.0f},
                                 20.0f},
                      RegionCase{"dim_point", scene::LightType::Point, {-4.0f, 1.5f, 2.0f}, {0.0f, -1.0f, 0.0f}, 50.0f,
                                 0.05f, true},
                      RegionCase{"point", scene::LightType::Point, {2.0f, 5.0f, 2.0f}, {0.0f, -1.0f, 0.0f}},
                      RegionCase{"rect", scene::LightType::Rect, {2.0f, 6.0f, 2.0f}, {0.0f, -1.0f, 0.0f}},
                      RegionCase{"disk", scene::LightType::Disk, {-2.0f, 6.0f, 3.0f}, {0.2f, -1.0f, 0.0f}},
                      RegionCase{"directional", scene::LightType::Directional, {0.0f, 10.0f, 0.0f}, {0.3f, -1.0f, 0.2f}}),
    [](const auto& info) { return std::string(info.param.name); });
