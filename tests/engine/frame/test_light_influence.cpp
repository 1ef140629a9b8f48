// Which lights can matter (frame/LightInfluence.h), without a device: each light type's
// influence against receiver boxes, at every scale and tilt the tests sweep, the cutoff's
// range, the guards (zero and NaN intensity, the apex inside a box) and the ranking that
// max_shadowed_lights keeps.
#include "penumbra/frame/LightInfluence.h"
#include "penumbra/render/Projection.h"

#include <gtest/gtest.h>
#include <glm/gtc/matrix_transform.hpp>

#include <cmath>
#include <limits>

using namespace penumbra;
using frame::LightFate;

namespace {

scene::Aabb box(glm::vec3 lo, glm::vec3 hi)
{
    scene::Aabb b;
    b.extend(lo);
    b.extend(hi);
    return b;
}

// A floor of half-size h at y = 0, 1 mm thick at scale 1.
scene::Aabb floorBox(float h, float scale = 1.0f) { return box({-h, -0.001f * scale, -h}, {h, 0.001f * scale, h}); }

scene::Light spot(glm::vec3 position, glm::vec3 direction, float outerDeg = 30.0f, float intensity = 900.0f)
{
    scene::Light l;
    l.type = scene::LightType::Spot;
    l.position = position;
    l.direction = glm::normalize(direction);
    l.outerConeDeg = outerDeg;
    l.innerConeDeg = outerDeg * 0.8f;
    l.intensity = intensity;
    return l;
}

scene::Light ofType(scene::LightType type, glm::vec3 position, glm::vec3 direction, float intensity = 900.0f)
{
    scene::Light l = spot(position, direction, 30.0f, intensity);
    l.type = type;
    l.sizeWorld = glm::vec2(1.0f);
    l.radiusWorld = 0.5f;
    return l;
}

// A camera over the floor looking at its centre.
frame::LightCullingInput lookingAt(std::vector<scene::Aabb> boxes, std::span<const scene::Light> lights, float scale = 1.0f)
{
    scene::Camera camera;
    camera.position = glm::vec3(0.0f, 8.0f, 12.0f) * scale;
    camera.target = glm::vec3(0.0f);
    camera.nearWorld = 0.05f * scale;
    frame::LightCullingInput input;
    input.cameraViewProj = render::cameraViewProj(camera, 16.0f / 9.0f);
    input.cameraPosition = camera.position;
    input.lights = lights;
    input.shadowed.assign(lights.size(), true);
    input.visibleBoxes = std::move(boxes);
    return input;
}

} // namespace

TEST(LightInfluence, ASpotReachesWhatItsConeMeetsAtEveryTiltAndScale)
{
    for (float scale : {1e-3f, 1.0f, 1e3f}) {
        const scene::Aabb floor = floorBox(10.0f * scale, scale);
        // From 5 above the floor, tilted from straight down (0) to straight up (180): the
        // 30-degree cone meets the 10-wide floor while its near edge points below the
        // horizon by more than atan(5/10), i.e. for tilts below 90 + 30 - 26.6 degrees.
        for (float tilt = 0.0f; tilt <= 180.0f; tilt += 7.5f) {
            const float t = glm::radians(tilt);
            const scene::Light light = spot(glm::vec3(0.0f, 5.0f * scale, 0.0f), {std::sin(t), -std::cos(t), 0.0f});
            const double bound = frame::lightRadianceBound(light, floor, 1.0);
            const double edgeTilt = 90.0 + 30.0 - glm::degrees(std::atan(0.5));
            if (tilt < edgeTilt - 0.5) {
                EXPECT_GT(bound, 0.0) << "tilt " << tilt << " scale " << scale;
            } else if (tilt > edgeTilt + 0.5) {
                EXPECT_EQ(bound, 0.0) << "tilt " << tilt << " scale " << scale;
            }
        }
    }
}

TEST(LightInfluence, AFlatFloorBelowASpotPointingUpIsNotReachedThoughItsSphereHoldsTheSpot)
{
    // The floor's bounding sphere (radius 28) holds the light 5 above it: only splitting
    // the box tells that the cone, pointing up, meets none of it.
    const scene::Light up = spot({0.0f, 5.0f, 0.0f}, {0.05f, 1.0f, 0.0f});
    EXPECT_EQ(frame::lightRadianceBound(up, floorBox(20.0f), 1.0), 0.0);
    // A box around the light is always reached, whatever its direction.
    EXPECT_GT(frame::lightRadianceBound(up, box({-1, 4, -1}, {1, 6, 1}), 1.0), 0.0);
}

TEST(LightInfluence, RectAndDiskLightsReachOnlyWhatLiesInFrontOfTheirEmittingSide)
{
    for (scene::LightType type : {scene::LightType::Rect, scene::LightType::Disk}) {
        const scene::Light facingDown = ofType(type, {0.0f, 3.0f, 0.0f}, {0.0f, -1.0f, 0.0f});
        const scene::Light facingUp = ofType(type, {0.0f, 3.0f, 0.0f}, {0.0f, 1.0f, 0.0f});
        EXPECT_GT(frame::lightRadianceBound(facingDown, floorBox(10.0f), 1.0), 0.0);
        EXPECT_EQ(frame::lightRadianceBound(facingUp, floorBox(10.0f), 1.0), 0.0);
        // A box straddling the emitter's plane is reached.
        EXPECT_GT(frame::lightRadianceBound(facingUp, box({-1, 2, -1}, {1, 3.5f, 1}), 1.0), 0.0);
    }
}

TEST(LightInfluence, PointAndAreaLightsReachUpToTheRangeWhereTheirRadianceFallsBelowTheCutoff)
{
    for (scene::LightType type : {scene::LightType::Point, scene::LightType::Spot, scene::LightType::Rect}) {
        for (float intensity : {1e-3f, 1.0f, 900.0f, 1e7f}) {
            const scene::Light light = ofType(type, {0.0f, 0.0f, 0.0f}, {1.0f, 0.0f, 0.0f}, intensity);
            const double range = frame::lightRange(light, 1.0);
            // I / (pi d^2) = cutoff at the range.
            EXPECT_NEAR(intensity / (M_PI * range * range), frame::kLightCutoffRadiance, 1e-9 * frame::kLightCutoffRadiance);
            const auto at = [&](double d) {
                const glm::vec3 p(float(d), 0.0f, 0.0f);
                return frame::lightRadianceBound(light, box(p, p + glm::vec3(0.01f * float(range))), 1.0);
            };
            EXPECT_GE(at(0.99 * range), frame::kLightCutoffRadiance) << intensity;
            EXPECT_LT(at(1.01 * range), frame::kLightCutoffRadiance) << intensity;
        }
    }
    scene::Light sun = ofType(scene::LightType::Directional, {}, {0.0f, -1.0f, 0.0f}, 3.0f);
    EXPECT_TRUE(std::isinf(frame::lightRange(sun, 1.0)));
}

TEST(LightInfluence, ZeroLightsReachNothingAndANaNIsNeverCulled)
{
    for (scene::LightType type : {scene::LightType::Directional, scene::LightType::Spot, scene::LightType::Point,
                                  scene::LightType::Rect, scene::LightType::Disk}) {
        scene::Light light = ofType(type, {0.0f, 3.0f, 0.0f}, {0.0f, -1.0f, 0.0f}, 0.0f);
        EXPECT_EQ(frame::lightRadianceBound(light, floorBox(10.0f), 1.0), 0.0);
        light.intensity = 10.0f;
        light.color = glm::vec3(0.0f);
        EXPECT_EQ(frame::lightRadianceBound(light, floorBox(10.0f), 1.0), 0.0);
        light.color = glm::vec3(1.0f);
        light.intensity = std::numeric_limits<float>::quiet_NaN();
        EXPECT_GT(frame::lightRadianceBound(light, floorBox(10.0f), 1.0), 0.0);
    }
}

TEST(LightInfluence, DecisionsCullWhatCannotMatterAndSayWhy)
{
    const std::vector<scene::Light> lights = {
        spot({0.0f, 10.0f, 0.0f}, {0.0f, -1.0f, 0.0f}),                              // 0: on the floor
        spot({0.0f, 10.0f, 0.0f}, {0.0f, 1.0f, 0.1f}),                               // 1: pointing up
        spot({200.0f, 10.0f, 0.0f}, {0.0f, -1.0f, 0.0f}),                            // 2: on a floor out of view
        ofType(scene::LightType::Point, {0.0f, 3.0f, 0.0f}, {0, -1, 0}, 0.0f),       // 3: zero intensity
        ofType(scene::LightType::Point, {1e5f, 3.0f, 0.0f}, {0, -1, 0}, 1.0f),       // 4: beyond its range
        ofType(scene::LightType::Directional, {}, {0.3f, -1.0f, 0.0f}, 2.0f),        // 5: the sun
    };
    const std::vector<frame::LightDecision> d = frame::decideLights(lookingAt({floorBox(10.0f)}, lights));
    ASSERT_EQ(d.size(), lights.size());
    EXPECT_EQ(d[0].fate, LightFate::Shadowed);
    EXPECT_EQ(d[1].fate, LightFate::Culled);
    EXPECT_NE(d[1].why.find("cone"), std::string::npos) << d[1].why;
    EXPECT_EQ(d[2].fate, LightFate::Culled);
    EXPECT_EQ(d[3].fate, LightFate::Culled);
    EXPECT_NE(d[3].why.find("intensity or colour is 0"), std::string::npos) << d[3].why;
    EXPECT_EQ(d[4].fate, LightFate::Culled);
    EXPECT_NE(d[4].why.find("range"), std::string::npos) << d[4].why;
    EXPECT_EQ(d[5].fate, LightFate::Shadowed);

    // light_culling off: every light draws.
    frame::LightCullingInput all = lookingAt({floorBox(10.0f)}, lights);
    all.cullLights = false;
    for (const frame::LightDecision& decision : frame::decideLights(all)) EXPECT_EQ(decision.fate, LightFate::Shadowed);

    // Nothing in view: nothing matters (the light of zero intensity says so first).
    const std::vector<frame::LightDecision> none = frame::decideLights(lookingAt({}, lights));
    for (size_t i = 0; i < none.size(); ++i) {
        EXPECT_EQ(none[i].fate, LightFate::Culled);
        EXPECT_NE(none[i].why.find(i == 3 ? "intensity or colour is 0" : "sees no receiver"), std::string::npos) << i;
    }
}

TEST(LightInfluence, MaxShadowedLightsKeepsShadowsOnTheLightsThatContributeMost)
{
    const std::vector<scene::Light> lights = {
        spot({0.0f, 10.0f, 0.0f}, {0.0f, -1.0f, 0.0f}, 30.0f, 100.0f),   // dim
        spot({0.0f, 10.0f, 0.0f}, {0.0f, -1.0f, 0.0f}, 30.0f, 1000.0f),  // bright
        spot({0.0f, 10.0f, 0.0f}, {0.0f, -1.0f, 0.0f}, 30.0f, 300.0f),   // between
        spot({0.0f, 10.0f, 0.0f}, {0.0f, -1.0f, 0.0f}, 30.0f, 1000.0f),  // as bright as 1: ranks after it
    };
    for (uint32_t keep = 1; keep <= 4; ++keep) {
        frame::LightCullingInput input = lookingAt({floorBox(10.0f)}, lights);
        input.maxShadowedLights = keep;
        input.shadowed[2] = false;  // technique "none": never ranked, never demoted
        const std::vector<frame::LightDecision> d = frame::decideLights(input);
        EXPECT_GT(d[1].importance, d[0].importance);
        const uint32_t order[] = {1, 3, 0};  // by importance, ties by index
        for (uint32_t r = 0; r < 3; ++r) {
            EXPECT_EQ(d[order[r]].fate, r < keep ? LightFate::Shadowed : LightFate::Unshadowed) << keep << " " << r;
            if (r >= keep) {
                EXPECT_NE(d[order[r]].why.find("max_shadowed_lights"), std::string::npos);
            }
        }
        EXPECT_EQ(d[2].fate, LightFate::Unshadowed);
        EXPECT_TRUE(d[2].why.empty());
    }
}
