// The visibility service (engine/src/visibility/): every culling mode gives the visibility
// image that drawing every caster gives (max |ΔV| <= 1e-3, the issue's bound), for every
// light type and for techniques with wide lookups, along an animated path, with a caster
// outside the camera's frustum and thin casters seen edge-on; and culling does cull.
#include "CasterOracle.h"
#include "TestConfigs.h"
#include "TestContext.h"

#include "engine/src/visibility/ReceiverScatter.h"

#include "penumbra/config/Config.h"
#include "penumbra/frame/FrameRenderer.h"
#include "penumbra/gpu/Barrier.h"
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/gpu/ShaderCompiler.h"
#include "penumbra/render/Projection.h"
#include "penumbra/scene/Generators.h"

#include <fmt/format.h>
#include <glm/gtc/matrix_transform.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <random>
#include <ostream>
#include <iterator>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

using namespace penumbra;

namespace {

using config::CullingMode;

constexpr float kMaxVisibilityChange = 1e-3f;

struct CulledFrame {
    std::vector<float> visibility;
    std::vector<float> positions;
    visibility::CullingStats stats;
};

::testing::AssertionResult sameVisibility(const std::vector<float>& expected, const std::vector<float>& actual,
                                          uint32_t width)
{
    if (expected.size() != actual.size()) return ::testing::AssertionFailure() << "image sizes differ";
    float worst = 0.0f;
    size_t where = 0, changed = 0;
    for (size_t i = 0; i < expected.size(); ++i) {
        const float d = std::abs(expected[i] - actual[i]);
        if (!(d <= kMaxVisibilityChange)) ++changed;
        if (!(d <= worst)) {
            worst = d;
            where = i;
        }
    }
    if (changed == 0) return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure() << changed << " pixels change by more than " << kMaxVisibilityChange
                                         << "; the worst, " << worst << ", at (" << where % width << ", "
                                         << where / width << "): " << expected[where] << " -> " << actual[where];
}

size_t countBelow(const std::vector<float>& v, float threshold)
{
    size_t n = 0;
    for (const float x : v) n += x < threshold ? 1 : 0;
    return n;
}

class VisibilityCulling : public test::GpuTest {
protected:
    CulledFrame render(const scene::Scene& scene, config::RenderConfig cfg, CullingMode mode)
    {
        cfg.culling = mode;
        frame::FrameRenderer renderer(*context, scene, cfg, test::plugins());
        const frame::FrameTimings t = renderer.renderFrame();
        return {renderer.readVisibility(0), renderer.readPositions(), t.culling};
    }

    // Renders `cfg` with every mode and expects each to give none's image.
    void expectEveryModeMatches(const scene::Scene& scene, const config::RenderConfig& cfg)
    {
        const CulledFrame all = render(scene, cfg, CullingMode::None);
        for (const CullingMode mode : {CullingMode::Frustum, CullingMode::LightOcclusion, CullingMode::ReceiverMask}) {
            SCOPED_TRACE(config::cullingModeName(mode));
            const CulledFrame culled = render(scene, cfg, mode);
            EXPECT_TRUE(sameVisibility(all.visibility, culled.visibility, cfg.width));
            // The G-buffer draws only the instances the camera sees: same surfaces.
            EXPECT_EQ(all.positions, culled.positions);
            EXPECT_LE(culled.stats.castersDrawn, all.stats.castersDrawn);
        }
    }
};

config::RenderConfig smallDefault(scene::LightType type, const std::string& technique, const nlohmann::json& params)
{
    config::RenderConfig cfg = test::defaultTestConfig();
    cfg.width = 160;
    cfg.height = 90;
    // The tests compare each frame's culling figures: every caster pass runs every frame.
    cfg.keepUnchanged = false;
    test::setLightType(cfg.lights[0], type);
    cfg.lights[0].shadow = {};
    cfg.lights[0].shadow.technique = technique;
    for (const auto& [name, value] : params.items()) cfg.lights[0].shadow.setParam(name, value, "test");
    return cfg;
}

struct TechniqueCase {
    const char* name;
    const char* technique;
    const char* params;  // JSON
};

// Techniques whose lookups reach from one texel (hard) to wide kernels (PCF 7 x 7, PCSS's
// blocker search, VSM's blur) and to the whole map (a mip chain).
// hard with slope or constant bias, PCF, Poisson, bilinear and PCSS with slope bias
// compare with the receivers' own depth (CasterView::compareTapRadius: their casters are
// tested against the receivers' depths, spread over taps of radius 0, 3, 2, 1 and 65);
// normal offset, receiver planes and VSM use the receiver mask alone.
const TechniqueCase kTechniques[] = {
    {"hard", "hard", R"({"resolution": 512})"},
    {"hard_constant", "hard", R"({"resolution": 512, "bias_mode": "constant", "depth_bias": 64})"},
    {"hard_normal_offset", "hard", R"({"resolution": 512, "bias_mode": "normal_offset"})"},
    {"pcf7", "hard", R"({"resolution": 512, "filter": "pcf", "pcf_kernel": 7})"},
    {"poisson", "hard", R"({"resolution": 512, "filter": "poisson", "filter_radius": 1.5})"},
    {"bilinear", "hard", R"({"resolution": 512, "filter": "bilinear"})"},
    {"pcss", "pcss", R"({"resolution": 512})"},
    {"pcss_slope", "pcss", R"({"resolution": 512, "bias_mode": "slope"})"},
    {"vsm_blur", "vsm", R"({"resolution": 512, "blur_radius": 4})"},
    {"vsm_mips", "vsm", R"({"resolution": 512, "filter": "trilinear"})"},
    {"backprojection", "backprojection", R"({"resolution": 512, "light_size": 0.6})"},  // kernels up to its cap
    // Its depth-peeled second layer: casters behind others from the light are drawn too.
    {"backprojection_layers", "backprojection", R"({"resolution": 512, "light_size": 0.6, "layers": 2})"},
    {"example", "example", R"({"resolution": 512})"},  // the SDK's example: hard's one compare, declared by hand
    // Fragment lists: every caster fragment, not the nearest; PCF 3 x 3 over the links.
    {"deep", "deep", R"({"resolution": 512, "pcf_kernel": 3})"},
    // Tiles kept from frame to frame, each drawn with its own cropped view: every caster
    // in it that light-space culling keeps (no receiver-dependent culling), PCF 3 x 3 across
    // tile borders.
    {"adaptive_sm", "adaptive-sm", R"({"pcf_kernel": 3})"},
};

void PrintTo(const TechniqueCase& c, std::ostream* os) { *os << c.name; }

class CullingPerTechnique : public VisibilityCulling,
                            public ::testing::WithParamInterface<std::tuple<TechniqueCase, scene::LightType>> {};

TEST_P(CullingPerTechnique, EveryModeGivesTheImageOfAllCasters)
{
    const auto& [technique, type] = GetParam();
    config::RenderConfig cfg = smallDefault(type, technique.technique, nlohmann::json::parse(technique.params));
    scene::Scene scene = config::buildScene(cfg);
    expectEveryModeMatches(scene, cfg);
}

INSTANTIATE_TEST_SUITE_P(Visibility, CullingPerTechnique,
                         ::testing::Combine(::testing::ValuesIn(kTechniques),
                                            ::testing::Values(scene::LightType::Directional, scene::LightType::Spot,
                                                              scene::LightType::Point, scene::LightType::Rect)),
                         [](const auto& info) {
                             return std::string(std::get<0>(info.param).name) + "_" +
                                    scene::lightTypeName(std::get<1>(info.param));
                         });

// A translucent (BLEND) roof over the default scene's boxes, between them and the light:
// light-space occlusion culling must not let it hide the boxes (a deep shadow map draws
// every fragment behind it; the boxes darken the ground under the roof's 0.7).
TEST_F(VisibilityCulling, ATranslucentCasterHidesNothingBehindIt)
{
    config::RenderConfig cfg = smallDefault(scene::LightType::Spot, "deep", {{"resolution", 512}});
    scene::Scene scene = config::buildScene(cfg);
    scene.materials.push_back({"glass", {1.0f, 1.0f, 1.0f, 0.3f}, scene::kNoTexture, scene::AlphaMode::Blend, 0.5f, true});
    scene::Mesh roof = scene::makePlane("roof");
    roof.material = uint32_t(scene.materials.size() - 1);
    const glm::vec3 light = cfg.lights[0].light.position;
    test::addInstance(scene, test::addMesh(scene, roof), "roof",
                      glm::scale(glm::translate(glm::mat4(1.0f), {light.x, 0.8f * light.y, light.z}),
                                 glm::vec3(40.0f, 1.0f, 40.0f)));
    scene.updateTransforms();
    const CulledFrame all = render(scene, cfg, CullingMode::None);
    ASSERT_GT(countBelow(all.visibility, 0.5f), cfg.width * cfg.height / 50) << "the boxes' shadows under the roof";
    expectEveryModeMatches(scene, cfg);
}

// A tall box behind the camera, outside its frustum, shadows the ground the camera looks
// at: its shadow must survive every mode (it is drawn because it covers masked texels,
// not because the camera sees it).
TEST_F(VisibilityCulling, ACasterOutsideTheViewShadowsAVisibleReceiver)
{
    scene::Scene scene = test::planeScene();
    test::addInstance(scene, test::addMesh(scene, scene::makeBox("tower")), "tower",
                      glm::scale(glm::translate(glm::mat4(1.0f), {-6.0f, 4.0f, 0.0f}), glm::vec3(1.0f, 8.0f, 1.0f)));
    config::RenderConfig cfg = smallDefault(scene::LightType::Directional, "hard", {{"resolution", 512}});
    cfg.camera.position = {2.0f, 3.0f, 0.0f};
    cfg.camera.target = {6.0f, 0.0f, 0.0f};
    cfg.camera.up = {0.0f, 1.0f, 0.0f};
    cfg.lights[0].light.direction = glm::normalize(glm::vec3(1.0f, -0.7f, 0.0f));
    // The tower is outside the camera's view.
    const glm::mat4 viewProj = render::cameraViewProj(cfg.camera, float(cfg.width) / float(cfg.height));
    const glm::vec4 tower = viewProj * glm::vec4(-6.0f, 4.0f, 0.0f, 1.0f);
    ASSERT_TRUE(tower.w < 0.0f || std::abs(tower.x) > tower.w || std::abs(tower.y) > tower.w);

    const CulledFrame all = render(scene, cfg, CullingMode::None);
    ASSERT_GT(countBelow(all.visibility, 0.5f), cfg.width * cfg.height / 50) << "the tower's shadow is in view";
    for (const CullingMode mode : {CullingMode::Frustum, CullingMode::LightOcclusion, CullingMode::ReceiverMask}) {
        SCOPED_TRACE(config::cullingModeName(mode));
        const CulledFrame culled = render(scene, cfg, mode);
        EXPECT_TRUE(sameVisibility(all.visibility, culled.visibility, cfg.width));
        // The frustum leaves the tower out of the G-buffer; light-occlusion culls per BVH
        // leaf, and one leaf holds both instances. Receiver-mask with hard's slope bias
        // tests each instance on the CPU: the ground lies behind its own receiver depths
        // once biased, and only the tower is drawn.
        if (mode == CullingMode::Frustum) {
            EXPECT_EQ(culled.stats.receivers, 1u) << "the camera sees only the ground";
        }
        if (mode == CullingMode::ReceiverMask)
            EXPECT_EQ(culled.stats.castersDrawn, 1u) << "the tower";
        else
            EXPECT_EQ(culled.stats.castersDrawn, 2u) << "ground and tower";
    }
}

// Shadow-map focusing, on a ground 400 m across seen from close by (about 25 m of it),
// with a tower behind the camera, outside its view, and a post in it: a 256² map fitted
// to what the camera sees must come out much closer to a 4096² map's than one fitted to
// the whole light, and the tower must still cast. `cfg`'s light 0 is set up by the test.
class ShadowFocus : public VisibilityCulling {
protected:
    static config::RenderConfig focusConfig(scene::LightType type)
    {
        config::RenderConfig cfg = smallDefault(type, "hard", {{"resolution", 4096}});
        cfg.camera.position = {2.0f, 3.0f, 0.0f};
        cfg.camera.target = {6.0f, 0.0f, 0.0f};
        cfg.camera.up = {0.0f, 1.0f, 0.0f};
        return cfg;
    }

    void expectFocusingSharpens(config::RenderConfig cfg)
    {
        scene::Scene scene;
        test::addInstance(scene, test::addMesh(scene, scene::makePlane("ground")), "ground",
                          glm::scale(glm::mat4(1.0f), glm::vec3(400.0f, 1.0f, 400.0f)));
        const uint32_t box = test::addMesh(scene, scene::makeBox("box"));
        test::addInstance(scene, box, "tower",
                          glm::scale(glm::translate(glm::mat4(1.0f), {-6.0f, 4.0f, 0.0f}), glm::vec3(1.0f, 8.0f, 1.0f)));
        test::addInstance(scene, box, "post",
                          glm::scale(glm::translate(glm::mat4(1.0f), {7.0f, 0.6f, 1.5f}), glm::vec3(0.2f, 1.2f, 0.2f)));
        scene.updateTransforms();
        const CulledFrame fine = render(scene, cfg, CullingMode::None);

        cfg.lights[0].shadow.setParam("resolution", 256, "test");
        const CulledFrame coarse = render(scene, cfg, CullingMode::ReceiverMask);
        cfg.shadowFocus = true;
        const CulledFrame focused = render(scene, cfg, CullingMode::ReceiverMask);
        const auto meanError = [&](const CulledFrame& f) {
            double sum = 0.0;
            for (size_t i = 0; i < fine.visibility.size(); ++i) sum += std::abs(f.visibility[i] - fine.visibility[i]);
            return sum / double(fine.visibility.size());
        };
        const double coarseError = meanError(coarse), focusedError = meanError(focused);
        RecordProperty("mean_error_unfocused", std::to_string(coarseError));
        RecordProperty("mean_error_focused", std::to_string(focusedError));
        EXPECT_LT(focusedError, 0.25 * coarseError);
        EXPECT_LT(focusedError, 0.01);
        // The tower's and the post's shadows are both there.
        EXPECT_GT(countBelow(fine.visibility, 0.5f), 1000u);
        EXPECT_GT(countBelow(focused.visibility, 0.5f), countBelow(fine.visibility, 0.5f) * 9 / 10);

        cfg.culling = CullingMode::Frustum;
        try {
            frame::FrameRenderer renderer(*context, scene, cfg, test::plugins());
            ADD_FAILURE() << "focusing without an occlusion mode must be refused";
        } catch (const ConfigError& e) {
            EXPECT_NE(std::string(e.what()).find("shadow_focus"), std::string::npos) << e.what();
        }
    }
};

// A directional light's box: unfocused, a 256² map's texels are 1.6 m (mean error 0.062
// when written, focused 0.0048). Focusing keeps the scene's side nearest the light.
TEST_F(ShadowFocus, SharpensADirectionalShadowAndKeepsCastersOutsideTheView)
{
    config::RenderConfig cfg = focusConfig(scene::LightType::Directional);
    cfg.lights[0].light.direction = glm::normalize(glm::vec3(1.0f, -0.7f, 0.2f));
    expectFocusingSharpens(cfg);
}

// A spot light 20 m above the ground: its 140° cone spreads the map well beyond the
// ground; narrowed about its axis to what the camera sees, mean error 0.0010 against
// 0.114 unfocused when written. The cone keeps its apex, so the tower still casts.
TEST_F(ShadowFocus, NarrowsASpotLightsConeAndKeepsCastersOutsideTheView)
{
    config::RenderConfig cfg = focusConfig(scene::LightType::Spot);
    scene::Light& spot = cfg.lights[0].light;
    spot.position = {-40.0f, 20.0f, 0.0f};
    spot.direction = glm::normalize(glm::vec3(46.0f, -20.0f, 0.0f));
    spot.innerConeDeg = 60.0f;
    spot.outerConeDeg = 70.0f;
    expectFocusingSharpens(cfg);
}

// The focused cone's guards: a box that reaches around the light keeps the whole cone; a
// box far down the axis, thousands of times narrower than the cone, gives the narrowest
// cone allowed (1e-4 rad), not a degenerate matrix.
TEST(SpotFocus, ABoxAroundTheLightKeepsTheConeAndATinyBoxTheNarrowestCone)
{
    scene::Light spot;
    spot.type = scene::LightType::Spot;
    spot.position = {0.0f, 10.0f, 0.0f};
    spot.direction = {0.0f, -1.0f, 0.0f};
    spot.outerConeDeg = 45.0f;
    const scene::Aabb bounds{{-100.0f, -1.0f, -100.0f}, {100.0f, 20.0f, 100.0f}};
    const glm::mat4 cone = render::shadowFrusta(spot, bounds).front().proj;

    const scene::Aabb around{{-1.0f, 0.0f, -1.0f}, {1.0f, 11.0f, 1.0f}};
    EXPECT_EQ(render::shadowFrusta(spot, bounds, &around).front().proj, cone);

    const scene::Aabb beside{{20.0f, 0.0f, -1.0f}, {21.0f, 1.0f, 1.0f}};  // outside the 45° cone
    EXPECT_EQ(render::shadowFrusta(spot, bounds, &beside).front().proj, cone) << "never wider than the cone";

    const scene::Aabb tiny{{-1e-6f, 0.0f, -1e-6f}, {1e-6f, 1e-6f, 1e-6f}};
    const glm::mat4 narrow = render::shadowFrusta(spot, bounds, &tiny).front().proj;
    EXPECT_NEAR(-1.0f / narrow[1][1], 5e-5f, 1e-7f) << "tan of the half-angle (y is flipped for Vulkan)";
    EXPECT_TRUE(std::isfinite(narrow[0][0]) && std::isfinite(narrow[1][1]));
}

// Thin casters (zero-thickness quads) seen edge-on from the light, and from the camera:
// a slat that covers few texel centres of the map must be culled only when it covers
// none, as in the technique's own map.
TEST_F(VisibilityCulling, ThinCastersSeenEdgeOnKeepTheirShadows)
{
    scene::Scene scene = test::planeScene();
    const uint32_t slat = test::addMesh(scene, scene::makePlane("slat"));
    for (int i = 0; i < 12; ++i) {
        // Vertical unit quads (the plane turned about z) along x, each turned a little
        // more about y, so that the light sees some of them almost exactly edge-on.
        glm::mat4 m = glm::translate(glm::mat4(1.0f), {-5.0f + 0.9f * float(i), 1.2f, 0.0f});
        m = glm::rotate(m, glm::radians(-4.0f + 0.7f * float(i)), glm::vec3(0, 1, 0));
        m = glm::rotate(m, glm::radians(90.0f), glm::vec3(0, 0, 1));
        m = glm::scale(m, glm::vec3(2.0f, 1.0f, 2.0f));
        test::addInstance(scene, slat, "slat", m);
    }
    scene.updateTransforms();
    for (const char* params : {R"({"resolution": 512})", R"({"resolution": 512, "filter": "pcf", "pcf_kernel": 5})"}) {
        SCOPED_TRACE(params);
        config::RenderConfig cfg = smallDefault(scene::LightType::Directional, "hard", nlohmann::json::parse(params));
        cfg.lights[0].light.direction = glm::normalize(glm::vec3(0.02f, -1.0f, 0.45f));
        cfg.camera.position = {0.0f, 9.0f, 0.5f};  // the slats from above: edge-on to the camera too
        cfg.camera.target = {0.0f, 0.0f, 0.0f};
        cfg.camera.up = {0.0f, 0.0f, -1.0f};
        const CulledFrame all = render(scene, cfg, CullingMode::None);
        ASSERT_GT(countBelow(all.visibility, 0.5f), 0u);
        for (const CullingMode mode : {CullingMode::LightOcclusion, CullingMode::ReceiverMask}) {
            SCOPED_TRACE(config::cullingModeName(mode));
            EXPECT_TRUE(sameVisibility(all.visibility, render(scene, cfg, mode).visibility, cfg.width));
        }
    }
}

// An animated path: the camera walks and turns, the light swings, a box moves. Two
// renderers follow it in lockstep; the culled one matches the other on every frame: with
// PCSS's receiver planes (the mask alone: occlusion queries, with temporal coherence, last
// frame's visible nodes drawn without waiting) and with hard's slope bias (receiver depths:
// culled on the CPU against this frame's receivers, ReceiverFloorCulling.h).
class AnimatedCulling : public VisibilityCulling, public ::testing::WithParamInterface<const char*> {};

TEST_P(AnimatedCulling, AnAnimatedPathKeepsEveryFrameExact)
{
    // A street of a small city, where the receiver mask culls on every frame (no view
    // takes its frustum): the camera walks down the street and turns, the sun swings, and
    // an instance moves.
    scene::CityParams p;
    p.blocks = 3;
    p.seed = 5;
    scene::Scene sceneAll = scene::generateCity(p);
    scene::Scene sceneCulled = scene::generateCity(p);
    config::RenderConfig cfg = smallDefault(scene::LightType::Directional, GetParam(), {{"resolution", 1024}});
    cfg.camera.position = {38.0f, 1.7f, -100.0f};
    cfg.camera.target = {36.0f, 8.0f, 40.0f};
    cfg.camera.nearWorld = 0.1f;
    cfg.camera.fovYDeg = 60.0f;
    config::RenderConfig culledCfg = cfg;
    culledCfg.culling = CullingMode::ReceiverMask;
    frame::FrameRenderer all(*context, sceneAll, cfg, test::plugins());
    frame::FrameRenderer culled(*context, sceneCulled, culledCfg, test::plugins());
    const config::RenderConfig start = cfg;
    const auto moving = uint32_t(sceneAll.instances.size() - 1);
    const uint32_t node = sceneAll.instances[moving].node;
    const glm::mat4 rest = sceneAll.graph.local(node);
    for (int frame = 0; frame < 6; ++frame) {
        SCOPED_TRACE(frame);
        const float t = float(frame) / 5.0f;
        config::RenderConfig c = start;
        c.camera.position += glm::vec3(0.0f, 0.0f, 40.0f * t);
        c.camera.target += glm::vec3(-30.0f * t, 0.0f, 40.0f * t);
        c.lights[0].light.direction = glm::normalize(glm::vec3(0.6f - 0.8f * t, -0.45f, 0.35f + 0.3f * t));
        const glm::mat4 moved = glm::translate(glm::mat4(1.0f), {2.0f * t, 0.0f, 5.0f * t}) * rest;
        for (scene::Scene* s : {&sceneAll, &sceneCulled}) s->graph.setLocal(node, moved);
        config::RenderConfig cc = c;
        cc.culling = CullingMode::ReceiverMask;
        all.update(c, sceneAll, sceneAll.updateTransforms());
        culled.update(cc, sceneCulled, sceneCulled.updateTransforms());
        const frame::FrameTimings at = all.renderFrame();
        const frame::FrameTimings ct = culled.renderFrame();
        EXPECT_TRUE(sameVisibility(all.readVisibility(0), culled.readVisibility(0), cfg.width));
        EXPECT_EQ(ct.culling.viewsFellBack, 0u) << "the mask culls on every frame";
        EXPECT_LT(ct.culling.trianglesDrawn, at.culling.trianglesDrawn / 3);
    }
}

INSTANTIATE_TEST_SUITE_P(VisibilityCulling, AnimatedCulling, ::testing::Values("pcss", "hard"));

// Where culling keeps most instances (the default scene: the camera sees most of them and
// nearly every caster shadows something it sees), the camera and the light view take
// their frustums after the first frame and are culled in full again every 8 frames; the
// image never changes.
TEST_F(VisibilityCulling, AViewWhereCullingCannotPayTakesItsFrustum)
{
    config::RenderConfig cfg = smallDefault(scene::LightType::Spot, "hard", {{"resolution", 512}});
    const scene::Scene scene = config::buildScene(cfg);
    const CulledFrame all = render(scene, cfg, CullingMode::None);
    cfg.culling = CullingMode::ReceiverMask;
    frame::FrameRenderer renderer(*context, scene, cfg, test::plugins());
    for (int frame = 0; frame < 10; ++frame) {
        SCOPED_TRACE(frame);
        const frame::FrameTimings t = renderer.renderFrame();
        EXPECT_TRUE(sameVisibility(all.visibility, renderer.readVisibility(0), cfg.width));
        // Frames 0 and 9 are culled in full, the others take the frustum.
        EXPECT_EQ(t.culling.viewsFellBack, frame == 0 || frame == 9 ? 0u : 1u);
        EXPECT_EQ(t.culling.views, 1u);
        EXPECT_EQ(t.culling.cameraFellBack, frame == 0 || frame == 9 ? 0u : 1u) << "the camera sees most too";
        EXPECT_EQ(t.culling.maskMs > 0.0, frame == 0 || frame == 9) << "a mask only for a full culling";
    }
}

// A city's street seen from the street, in the sun, through `technique`.
config::RenderConfig streetView(const std::string& technique, const nlohmann::json& params)
{
    config::RenderConfig cfg = smallDefault(scene::LightType::Directional, technique, params);
    cfg.camera.position = {3.0f, 1.7f, -110.0f};
    cfg.camera.target = {-2.0f, 10.0f, 40.0f};
    cfg.camera.nearWorld = 0.1f;
    cfg.camera.fovYDeg = 60.0f;
    cfg.lights[0].light.direction = glm::normalize(glm::vec3(0.6f, -0.45f, 0.35f));
    return cfg;
}

// A city of 3 x 3 blocks, for the street views above.
scene::Scene smallCity(uint32_t seed)
{
    scene::CityParams p;
    p.blocks = 3;
    p.seed = seed;
    return scene::generateCity(p);
}

// In a city seen from the street the camera sees few of the instances, and the receiver
// mask keeps fewer casters than the light's own occlusion culling, which keeps fewer
// than its frustum: and all of them give one image.
TEST_F(VisibilityCulling, AStreetViewOfACityCullsMostCasters)
{
    const scene::Scene scene = smallCity(3);
    const config::RenderConfig cfg = streetView("hard", {{"resolution", 1024}});
    const CulledFrame all = render(scene, cfg, CullingMode::None);
    const CulledFrame frustum = render(scene, cfg, CullingMode::Frustum);
    const CulledFrame occlusion = render(scene, cfg, CullingMode::LightOcclusion);
    const CulledFrame mask = render(scene, cfg, CullingMode::ReceiverMask);
    for (const CulledFrame* f : {&frustum, &occlusion, &mask})
        EXPECT_TRUE(sameVisibility(all.visibility, f->visibility, cfg.width));
    EXPECT_LT(mask.stats.receivers, scene.instances.size() / 4) << "the camera sees few instances";
    EXPECT_LT(mask.stats.castersDrawn, occlusion.stats.castersDrawn);
    EXPECT_LT(occlusion.stats.castersDrawn, frustum.stats.castersDrawn);
    EXPECT_LT(mask.stats.trianglesDrawn, all.stats.trianglesDrawn / 4);
    EXPECT_GT(mask.stats.queriesIssued, 0u);
    EXPECT_GT(mask.stats.nodesVisited, 0u);
    EXPECT_GT(mask.stats.floorRejected, 0u) << "hard's slope bias: culled behind the receivers on the CPU";
}

// A technique whose map only its receivers' lookups read (hard, pcss:
// ShadowMap::setReadByLookupsOnly) gets a depth pass that clears and draws only the texels
// the frame's receivers can read: the bounds of the dilated receiver mask, with
// receiver-mask culling. On a street view that is a small part of the map, and the image
// stays that of every caster. Every other case renders the whole map: the frustum mode, a
// technique with passes over the whole map (vsm's blur), and a map shown as a debug image.
TEST_F(VisibilityCulling, ADepthPassRendersOnlyTheTexelsTheReceiversRead)
{
    const scene::Scene scene = smallCity(3);
    struct Case {
        std::string technique;
        nlohmann::json params;
        bool lookupsOnly;
    };
    const uint64_t wholeMap = 1024u * 1024u;
    for (const Case& c : {Case{"hard", {{"resolution", 1024}}, true},
                          Case{"pcss", {{"resolution", 1024}}, true},
                          Case{"vsm", {{"resolution", 1024}, {"blur_radius", 2}}, false}}) {
        SCOPED_TRACE(c.technique);
        config::RenderConfig cfg = streetView(c.technique, c.params);
        const CulledFrame all = render(scene, cfg, CullingMode::None);
        const CulledFrame frustum = render(scene, cfg, CullingMode::Frustum);
        const CulledFrame mask = render(scene, cfg, CullingMode::ReceiverMask);
        EXPECT_TRUE(sameVisibility(all.visibility, mask.visibility, cfg.width));
        EXPECT_EQ(frustum.stats.mapTexelsRendered, wholeMap);
        if (c.lookupsOnly) {
            EXPECT_GT(mask.stats.mapTexelsRendered, 0u);
            EXPECT_LT(mask.stats.mapTexelsRendered, wholeMap / 2) << "the street's receivers read a part of the map";
        } else {
            EXPECT_EQ(mask.stats.mapTexelsRendered, wholeMap);
        }
        // Shown as a debug image, the map is whole: the texels no receiver reads too.
        cfg.culling = CullingMode::ReceiverMask;
        frame::FrameRenderer shown(*context, scene, cfg, test::plugins());
        const std::string map = fmt::format("light0.{}.shadow_map", c.technique);
        const std::vector<std::string> names = shown.imageNames();
        ASSERT_NE(std::find(names.begin(), names.end(), map), names.end()) << map;
        shown.requestImage(map);
        EXPECT_EQ(shown.renderFrame().culling.mapTexelsRendered, wholeMap);
        EXPECT_TRUE(sameVisibility(all.visibility, shown.readVisibility(0), cfg.width));
    }
}

// Sets an environment variable for the scope (the variable unset after it).
class ScopedEnvironment {
public:
    ScopedEnvironment(const char* name, const char* value) : name_(name) { ::setenv(name, value, 1); }
    ~ScopedEnvironment() { ::unsetenv(name_); }
    ScopedEnvironment(const ScopedEnvironment&) = delete;
    ScopedEnvironment& operator=(const ScopedEnvironment&) = delete;

private:
    const char* name_;
};

// The receivers are scattered into the masks by the host on a CPU device and by the
// device's shaders elsewhere (visibility::scatterPlacementFor; PENUMBRA_RECEIVER_SCATTER
// picks one). Both give none's image on a street view, through techniques with marks
// only (vsm), with receiver depths (hard), and with receiver depths spread over taps
// (PCF 5 x 5, pcss), and cull alike: the same casters up to the rounding of the same
// float operations on two compilers (the triangle counts within 1 %). A value the
// variable does not know is an error that names it.
TEST_F(VisibilityCulling, HostAndDeviceScattersGiveNonesImageAndCullAlike)
{
    const scene::Scene scene = smallCity(5);
    struct Case {
        std::string name, technique;
        nlohmann::json params;
    };
    for (const Case& c : {Case{"hard", "hard", {{"resolution", 1024}}},
                          Case{"pcf5", "hard", {{"resolution", 1024}, {"filter", "pcf"}, {"pcf_kernel", 5}}},
                          Case{"pcss", "pcss", {{"resolution", 1024}}},
                          Case{"vsm", "vsm", {{"resolution", 1024}, {"blur_radius", 2}}}}) {
        SCOPED_TRACE(c.name);
        const config::RenderConfig cfg = streetView(c.technique, c.params);
        const CulledFrame all = render(scene, cfg, CullingMode::None);
        CulledFrame placed[2];
        for (const int host : {0, 1}) {
            const ScopedEnvironment placement("PENUMBRA_RECEIVER_SCATTER", host ? "host" : "device");
            placed[host] = render(scene, cfg, CullingMode::ReceiverMask);
            const char* name = host ? "host" : "device";
            EXPECT_TRUE(sameVisibility(all.visibility, placed[host].visibility, cfg.width)) << name;
            EXPECT_EQ(placed[host].stats.views, 1u);
            EXPECT_EQ(placed[host].stats.masksOnHost, host ? 1u : 0u);
        }
        const auto device = double(placed[0].stats.trianglesDrawn), host = double(placed[1].stats.trianglesDrawn);
        EXPECT_LT(device, double(all.stats.trianglesDrawn) / 4) << "culling culls";
        EXPECT_NEAR(host, device, 0.01 * device);
    }
    const ScopedEnvironment wrong("PENUMBRA_RECEIVER_SCATTER", "gpu");
    config::RenderConfig cfg = streetView("hard", {{"resolution", 256}});
    cfg.culling = CullingMode::ReceiverMask;
    try {
        frame::FrameRenderer renderer(*context, scene, cfg, test::plugins());
        renderer.renderFrame();
        ADD_FAILURE() << "PENUMBRA_RECEIVER_SCATTER=gpu was accepted";
    } catch (const std::exception& e) {
        EXPECT_NE(std::string(e.what()).find("PENUMBRA_RECEIVER_SCATTER=gpu"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("host, device or auto"), std::string::npos) << e.what();
    }
}

// The receiver depths are cleared only where the last frame wrote them
// (ReceiverMask::receiverDepthWritten): a frame culls as a first frame of its view does,
// whatever view came before. Under a slab a small box stands on the ground, the sun
// straight above: seen from above, the slab's top is the only receiver over the box,
// which lies behind it and is culled. Seen first from beside, under the slab, the ground
// there is a receiver too; a depth of it left over would keep the box (still exact, but
// drawn for nothing). Swept over the tap radius that spreads the depths (hard's nearest
// compare, PCF 3 x 3 and 9 x 9) and both orders.
TEST_F(VisibilityCulling, ReceiverDepthsOfTheLastFrameNeverKeepACaster)
{
    scene::Scene scene = test::planeScene();
    const uint32_t box = test::addMesh(scene, scene::makeBox("box"));
    test::addInstance(scene, box, "slab",
                      glm::scale(glm::translate(glm::mat4(1.0f), {0.0f, 3.0f, 0.0f}), glm::vec3(6.0f, 0.4f, 6.0f)));
    test::addInstance(scene, box, "small", glm::translate(glm::mat4(1.0f), {0.0f, 0.5f, 0.0f}));
    config::RenderConfig cfg = smallDefault(scene::LightType::Directional, "hard", {{"resolution", 512}});
    cfg.culling = CullingMode::ReceiverMask;
    cfg.lights[0].light.direction = glm::normalize(glm::vec3(0.05f, -1.0f, 0.02f));
    cfg.camera.up = {0.0f, 1.0f, 0.0f};
    const std::pair<glm::vec3, glm::vec3> beside{{9.0f, 0.6f, 0.5f}, {0.0f, 0.8f, 0.0f}};
    const std::pair<glm::vec3, glm::vec3> above{{0.5f, 14.0f, 9.0f}, {0.0f, 3.0f, 0.0f}};
    for (const int kernel : {1, 3, 9}) {
        config::RenderConfig c = cfg;
        if (kernel > 1) {
            c.lights[0].shadow.setParam("filter", "pcf", "test");
            c.lights[0].shadow.setParam("pcf_kernel", kernel, "test");
        }
        for (const bool besideFirst : {true, false}) {
            SCOPED_TRACE(fmt::format("pcf {}, {} first", kernel, besideFirst ? "beside" : "above"));
            config::RenderConfig first = c, second = c;
            std::tie(first.camera.position, first.camera.target) = besideFirst ? beside : above;
            std::tie(second.camera.position, second.camera.target) = besideFirst ? above : beside;
            frame::FrameRenderer fresh(*context, scene, second, test::plugins());
            const visibility::CullingStats expected = fresh.renderFrame().culling;
            frame::FrameRenderer continued(*context, scene, first, test::plugins());
            continued.renderFrame();
            continued.update(second, scene, {});
            // A view that kept most of its instances takes its frustum (and builds no
            // mask) until its next full culling: the depths left are the first view's.
            visibility::CullingStats actual;
            for (int frame = 0; frame < 16; ++frame) {
                actual = continued.renderFrame().culling;
                if (actual.viewsFellBack == 0 && actual.cameraFellBack == 0) break;
            }
            ASSERT_EQ(actual.viewsFellBack, 0u) << "a full culling within 16 frames";
            if (besideFirst) {
                EXPECT_EQ(expected.castersDrawn, 1u) << "from above, only the slab";
            }
            EXPECT_EQ(actual.castersDrawn, expected.castersDrawn);
            EXPECT_EQ(actual.trianglesDrawn, expected.trianglesDrawn);
            EXPECT_EQ(actual.floorRejected, expected.floorRejected);
            EXPECT_TRUE(sameVisibility(fresh.readVisibility(0), continued.readVisibility(0), c.width));
        }
    }
}

// A technique that compares with the receivers' own depth (hard, slope bias) needs no
// caster where the camera sees only lit ground: after the bias the ground lies behind
// every receiver depth its lookups compare with (CasterView::compareTapRadius). Also at
// 1e-3 and 1e5 of the size, where the slack given to the receiver depths
// (engine/receiver_scatter.comp) must scale with the scene: too little would cull a
// caster the technique draws, too much would keep the ground. With normal offset the
// lookups move off the receiver, only the mask applies, and the ground is drawn.
TEST_F(VisibilityCulling, ALitReceiverThatShadowsNothingIsNotDrawn)
{
    for (const float scale : {1e-3f, 1.0f, 1e5f}) {
        SCOPED_TRACE(scale);
        scene::Scene scene;
        scene.meshes = {scene::makePlane("plane")};
        scene.meshes[0].computeBounds();
        scene.addInstance(0, scene.graph.addNode("plane", scene::kNoParent,
                                                 glm::scale(glm::mat4(1.0f), glm::vec3(20.0f, 1.0f, 20.0f) * scale)));
        for (const char* bias : {"slope", "normal_offset"}) {
            SCOPED_TRACE(bias);
            config::RenderConfig cfg =
                smallDefault(scene::LightType::Directional, "hard", {{"resolution", 512}, {"bias_mode", bias}});
            cfg.camera.position = {2.0f, 3.0f, 0.0f};
            cfg.camera.target = {6.0f, 0.0f, 0.0f};
            cfg.camera.up = {0.0f, 1.0f, 0.0f};
            cfg.lights[0].light.direction = glm::normalize(glm::vec3(1.0f, -0.7f, 0.0f));
            test::scaleConfig(cfg, scale);
            const CulledFrame all = render(scene, cfg, CullingMode::None);
            const CulledFrame mask = render(scene, cfg, CullingMode::ReceiverMask);
            EXPECT_TRUE(sameVisibility(all.visibility, mask.visibility, cfg.width));
            EXPECT_EQ(countBelow(mask.visibility, 0.999f), 0u) << "the ground is lit";
            EXPECT_EQ(mask.stats.castersDrawn, std::string(bias) == "slope" ? 0u : 1u);
        }
    }
}

// Triangles drawn against the oracle, the instances that really shadow a pixel the camera
// sees (test::casterOracle). On a street view of a small city under a low sun, hard with
// slope bias (receiver depths, culled on the CPU: ReceiverFloorCulling.h) stays within 3
// times the oracle: it keeps every instance in front of a receiver, also those hidden
// behind other casters, and in front of receivers that face away from the sun, which the
// oracle skips; drawing those costs less than the occlusion queries that dropped them
// (docs/culling.md). With normal offset (the receiver mask alone, occlusion queries) the
// lit facades and ground the camera sees are drawn too.
TEST_F(VisibilityCulling, ReceiverDepthsKeepAStreetViewNearTheOracle)
{
    scene::CityParams p;
    p.blocks = 5;
    p.seed = 7;
    scene::Scene scene = scene::generateCity(p);
    const glm::vec3 c = scene.bounds().center();
    for (const char* bias : {"slope", "normal_offset"}) {
        SCOPED_TRACE(bias);
        config::RenderConfig cfg =
            smallDefault(scene::LightType::Directional, "hard", {{"resolution", 1024}, {"bias_mode", bias}});
        cfg.width = 320;
        cfg.height = 180;
        cfg.camera.position = {c.x + 40.0f, 1.7f, c.z - 150.0f};
        cfg.camera.target = {c.x + 36.0f, 12.0f, c.z + 200.0f};
        cfg.camera.nearWorld = 0.1f;
        cfg.camera.fovYDeg = 60.0f;
        cfg.lights[0].light.direction = glm::normalize(glm::vec3(0.6f, -0.35f, 0.35f));
        frame::FrameRenderer renderer(*context, scene, cfg, test::plugins());
        renderer.renderFrame();
        const test::CasterOracle oracle =
            test::casterOracle(scene, renderer.readPositions(), renderer.readNormals(),
                               -glm::normalize(glm::dvec3(cfg.lights[0].light.direction)));
        const CulledFrame all = render(scene, cfg, CullingMode::None);
        const CulledFrame mask = render(scene, cfg, CullingMode::ReceiverMask);
        EXPECT_TRUE(sameVisibility(all.visibility, mask.visibility, cfg.width));
        ASSERT_GT(oracle.triangles, 0u);
        // Measured: slope 11,222 triangles against an oracle of 4,312 (2.6), normal offset
        // 13,842 (3.2).
        const double ratio = double(mask.stats.trianglesDrawn) / double(oracle.triangles);
        const std::string figures = fmt::format("{} triangles drawn, oracle {}", mask.stats.trianglesDrawn,
                                                oracle.triangles);
        if (std::string(bias) == "slope") {
            EXPECT_LE(ratio, 3.0) << figures;
            EXPECT_GT(mask.stats.floorRejected, 0u);
        } else {
            EXPECT_GT(ratio, 1.5) << figures;
            EXPECT_EQ(mask.stats.floorRejected, 0u) << "no receiver depths";
        }
    }
}

// A camera that sees nothing leaves an empty receiver mask: no caster is drawn (the
// queries' render area shrinks to one texel, and every node is rejected), and the
// image is the one with every caster.
TEST_F(VisibilityCulling, ACameraThatSeesNothingDrawsNoCaster)
{
    config::RenderConfig cfg = smallDefault(scene::LightType::Directional, "hard", {{"resolution", 512}});
    cfg.camera.target = cfg.camera.position + glm::vec3(0.0f, 1.0f, 0.1f);  // up into the sky
    const scene::Scene scene = config::buildScene(cfg);
    const CulledFrame all = render(scene, cfg, CullingMode::None);
    const CulledFrame mask = render(scene, cfg, CullingMode::ReceiverMask);
    EXPECT_TRUE(sameVisibility(all.visibility, mask.visibility, cfg.width));
    EXPECT_EQ(mask.stats.receivers, 0u);
    EXPECT_EQ(mask.stats.castersDrawn, 0u);
    EXPECT_EQ(mask.stats.queriesIssued, 0u);
}

// The texels of `spread` (size² words) that are not the least of `texels` within `radius`
// (a square, clipped to the view).
size_t texelsNotTheSquareMinimum(const std::vector<uint32_t>& texels, const std::vector<uint32_t>& spread,
                                 int32_t size, int32_t radius)
{
    const auto n = size_t(size);
    size_t wrong = 0;
    for (int32_t y = 0; y < size; ++y) {
        for (int32_t x = 0; x < size; ++x) {
            uint32_t expected = ~0u;
            for (int32_t v = std::max(y - radius, 0); v <= std::min(y + radius, size - 1); ++v)
                for (int32_t u = std::max(x - radius, 0); u <= std::min(x + radius, size - 1); ++u)
                    expected = std::min(expected, texels[size_t(v) * n + size_t(u)]);
            wrong += spread[size_t(y) * n + size_t(x)] != expected ? 1 : 0;
        }
    }
    return wrong;
}

// The bounds of the texels that hold a depth.
visibility::TexelBounds writtenBounds(const std::vector<uint32_t>& texels, int32_t size)
{
    visibility::TexelBounds b;
    for (uint32_t y = 0; y < uint32_t(size); ++y)
        for (uint32_t x = 0; x < uint32_t(size); ++x)
            if (texels[size_t(y) * size_t(size) + x] != ~0u) {
                b.x0 = std::min(b.x0, x), b.y0 = std::min(b.y0, y);
                b.x1 = std::max(b.x1, x), b.y1 = std::max(b.y1, y);
            }
    return b;
}

// engine/receiver_depth_min.comp spreads each receiver's depth over the taps of radius r
// (the least value in a (2 r + 1)^2 square, running minima over blocks of 2 r + 1): the
// same as the brute-force minimum on random images (buffers, row by row), with most texels
// empty (all ones), for sizes that are and are not multiples of the block, and radii past
// the image. So does the host's (visibility/ReceiverScatter.h), also with the depths in a
// corner (it visits only the texels the written ones reach).
TEST_F(VisibilityCulling, ReceiverDepthsSpreadOverTheTapsExactly)
{
    const gpu::ShaderCompiler compiler({gpu::engineShaderDir()});
    gpu::ComputePipelineDesc desc;
    desc.name = "test.receiver_depth_min";
    desc.shader = "engine/receiver_depth_min.comp";
    desc.pushConstantBytes = 3 * sizeof(int32_t);
    const gpu::Pipeline spread(*context, compiler, desc);
    std::mt19937 random(6);
    struct Case {
        int32_t size, radius;
    };
    for (const Case c : {Case{37, 1}, Case{37, 5}, Case{37, 40}, Case{64, 3}, Case{100, 7}, Case{9, 4}}) {
        SCOPED_TRACE(fmt::format("size {}, radius {}", c.size, c.radius));
        const auto n = size_t(c.size);
        std::vector<uint32_t> texels(n * n, ~0u);
        for (uint32_t& t : texels)
            if (random() % 10 < 2) t = random() % 0x3f800000u;
        const VkDeviceSize bytes = texels.size() * sizeof(uint32_t);
        gpu::Buffer depth(*context, bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true, "test.depth");
        const gpu::Buffer prefix(*context, bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, false, "test.prefix");
        std::memcpy(depth.mapped(), texels.data(), bytes);
        context->submitAndWait([&](VkCommandBuffer cmd) {
            spread.bind(cmd);
            gpu::DescriptorPush().storageBuffer("Depth", depth).storageBuffer("Prefix", prefix).push(*context, cmd, spread);
            for (int32_t vertical = 0; vertical < 2; ++vertical) {
                const int32_t push[3] = {c.size, c.radius, vertical};
                spread.pushConstants(cmd, push, sizeof(push));
                spread.dispatchOver(cmd, uint32_t(n));
                gpu::memoryBarrier(cmd, gpu::access::kComputeStorageWrite, gpu::access::kComputeStorageReadWrite);
            }
            gpu::memoryBarrier(cmd, gpu::access::kComputeStorageWrite, gpu::access::kHostRead);
        });
        std::vector<uint32_t> spreadTexels(n * n);
        std::memcpy(spreadTexels.data(), depth.mapped(), bytes);
        EXPECT_EQ(texelsNotTheSquareMinimum(texels, spreadTexels, c.size, c.radius), 0u) << "the device's";
        // The host's (visibility/ReceiverScatter.h), which visits only what the written
        // texels reach: over the whole view, and with the depths in a corner only.
        std::vector<uint32_t> host = texels;
        visibility::spreadReceiverDepth(host, uint32_t(c.size), uint32_t(c.radius), writtenBounds(texels, c.size));
        EXPECT_EQ(texelsNotTheSquareMinimum(texels, host, c.size, c.radius), 0u) << "the host's";
        std::vector<uint32_t> corner(n * n, ~0u);
        for (size_t y = 0; y < n / 3; ++y)
            for (size_t x = n - n / 3; x < n; ++x) corner[y * n + x] = texels[y * n + x];
        host = corner;
        visibility::spreadReceiverDepth(host, uint32_t(c.size), uint32_t(c.radius), writtenBounds(corner, c.size));
        EXPECT_EQ(texelsNotTheSquareMinimum(corner, host, c.size, c.radius), 0u) << "the host's, a corner";
    }
}

TEST(CullingModeNames, ParseAndNameRoundTripAndBadNamesAreNamed)
{
    for (const CullingMode m :
         {CullingMode::None, CullingMode::Frustum, CullingMode::LightOcclusion, CullingMode::ReceiverMask})
        EXPECT_EQ(config::parseCullingMode(config::cullingModeName(m)), m);
    try {
        config::parseCullingMode("occlusion");
        FAIL() << "expected a ConfigError";
    } catch (const ConfigError& e) {
        EXPECT_NE(std::string(e.what()).find("'occlusion'"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("receiver-mask"), std::string::npos) << e.what();
    }
}

} // namespace
