// The pcss plugin (plugins/pcss) end to end, through frame::FrameRenderer: every light
// type against rays from the light away from penumbrae, light size 0 against the hard
// plugin, the penumbra's width against the analytic soft shadow of the penumbra scene
// (scene/Generators.h penumbraVisibility), and the guards: no blocker, a huge light, a
// blocker touching its receiver, grazing light, scene scales 1e-3 and 1e5.
#include "PenumbraMeasure.h"
#include "PluginFrame.h"
#include "RayCastAgreement.h"
#include "TestConfigs.h"
#include "TestContext.h"

#include "penumbra/config/Config.h"
#include "penumbra/core/Error.h"
#include "penumbra/plugin/PluginRegistry.h"
#include "penumbra/scene/Generators.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>
#include <map>
#include <string>

using namespace penumbra;
using test::kBinaryTolerance;

namespace {

struct PcssSettings : test::KernelSettings {
    int blockerSamples = 16;
    int filterSamples = 32;
};

void applyPcss(config::LightConfig& light, const PcssSettings& s)
{
    nlohmann::json params = s.params();
    params["blocker_samples"] = s.blockerSamples;
    params["filter_samples"] = s.filterSamples;
    test::setShadow(light, "pcss", params);
}

class PcssTest : public test::TechniqueTest<PcssSettings, applyPcss> {
protected:
    // Against rays from the light's centre: a pixel whose neighbourhood (as far as the
    // blocker search or the filter reach, plus two texels) is all lit or all shadowed in
    // the centre's view has no blocker in reach (V = 1) or only blockers (V = 0).
    void expectRayCastAgreement(const std::vector<float>& v, const PcssSettings& s, const std::string& label)
    {
        PluginGpuTest::expectRayCastAgreement(v, s.bandTexels(), kBinaryTolerance, label);
    }
};

// ---------------------------------------------------------------------------------
// Every light type, in the default scene.

// The directional light's map spans the whole scene: twice the texels keep the band
// around edges as narrow in world units as the spot light's (LightCase::resolution).
using test::LightCase;

class PcssLightTypes : public PcssTest, public ::testing::WithParamInterface<LightCase> {};

} // namespace

TEST_P(PcssLightTypes, MatchesRayCastAwayFromPenumbrae)
{
    const LightCase& c = GetParam();
    config::RenderConfig cfg = test::defaultTestConfig();
    test::setLightType(cfg.lights[0], c.type);
    if (c.type == scene::LightType::Directional) cfg.lights[0].light.angularDiameterDeg = 2.0f;
    PcssSettings s;
    s.lightSize = c.lightSize;
    s.resolution = c.resolution;
    const std::vector<float> v = renderWith(cfg, s);
    expectRayCastAgreement(v, s, c.name);
    size_t soft = 0;
    for (float x : v) soft += x > 0.02f && x < 0.98f;
    EXPECT_GT(soft, 200u) << "a light with a size casts penumbrae";
}

INSTANTIATE_TEST_SUITE_P(Pcss, PcssLightTypes,
                         ::testing::Values(LightCase{"spot", scene::LightType::Spot, 0.6},
                                           LightCase{"directional", scene::LightType::Directional, -1.0, 2048},
                                           LightCase{"point", scene::LightType::Point, 0.4},
                                           LightCase{"rect", scene::LightType::Rect, -1.0},
                                           LightCase{"disk", scene::LightType::Disk, -1.0}),
                         [](const ::testing::TestParamInfo<LightCase>& info) { return std::string(info.param.name); });

// ---------------------------------------------------------------------------------
// Light size 0: the hard shadow's one compare, with the same bias.

namespace {

struct ZeroSizeCase {
    const char* name;
    scene::LightType type;
    const char* biasMode;
};

std::ostream& operator<<(std::ostream& os, const ZeroSizeCase& c) { return os << c.name; }

class PcssZeroSize : public PcssTest, public ::testing::WithParamInterface<ZeroSizeCase> {};

} // namespace

TEST_P(PcssZeroSize, EqualsTheHardShadow)
{
    const ZeroSizeCase& c = GetParam();
    config::RenderConfig cfg = test::defaultTestConfig();
    test::setLightType(cfg.lights[0], c.type);
    PcssSettings s;
    s.lightSize = 0.0;
    s.biasMode = c.biasMode;
    const std::vector<float> pcss = renderWith(cfg, s);

    config::ShadowSettings& hard = cfg.lights[0].shadow;
    hard = {};
    hard.technique = "hard";
    hard.required = true;
    hard.setParam("bias_mode", c.biasMode, "test");
    hard.setParam("filter", "none", "test");
    hard.setParam("resolution", s.resolution, "test");
    render(cfg, config::buildScene(cfg.scene));
    const std::vector<float> reference = frame->renderer.readVisibility(0);

    // Both compare the same map at the same texel against the same reference depth.
    size_t differ = 0, shadowed = 0;
    for (size_t i = 0; i < pcss.size(); ++i) {
        differ += std::abs(pcss[i] - reference[i]) > 1e-6f;
        shadowed += reference[i] == 0.0f;
    }
    EXPECT_EQ(differ, 0u) << c.name << ": pixels where |V_pcss - V_hard| > 1e-6";
    EXPECT_GT(shadowed, pcss.size() / 50) << "the scene has shadows to compare";
}

INSTANTIATE_TEST_SUITE_P(Pcss, PcssZeroSize,
                         ::testing::Values(ZeroSizeCase{"spot_receiver_plane", scene::LightType::Spot, "receiver_plane"},
                                           ZeroSizeCase{"spot_slope", scene::LightType::Spot, "slope"},
                                           ZeroSizeCase{"point_receiver_plane", scene::LightType::Point,
                                                        "receiver_plane"},
                                           ZeroSizeCase{"directional_slope", scene::LightType::Directional, "slope"}),
                         [](const ::testing::TestParamInfo<ZeroSizeCase>& info) {
                             return std::string(info.param.name);
                         });

// ---------------------------------------------------------------------------------
// The penumbra scene: a 1 x 1 plate h above the ground under a square light of side w at
// H = 3; along x the exact penumbra is w h / (H - h) wide (Generators.h).

namespace {

using test::PenumbraSetup;

// Wide radii: the penumbrae here are up to 42 texels wide at 1024 texels per cube face.
PcssSettings penumbraPcss()
{
    PcssSettings s;
    s.maxSearchTexels = 64.0;
    s.maxFilterTexels = 64.0;
    s.blockerSamples = 32;
    s.filterSamples = 64;
    return s;
}

class PcssPenumbra : public PcssTest {
protected:
    test::PenumbraWidths measure(const PenumbraSetup& p, const PcssSettings& s = penumbraPcss())
    {
        const std::vector<float> v =
            renderWith(test::penumbraConfig(p), s, scene::generatePenumbra(test::penumbraParams(p)));
        return test::measurePenumbra(*frame, v, p);
    }
};

} // namespace

TEST_F(PcssPenumbra, WidthGrowsWithLightSizeAndFollowsTheExactPenumbra)
{
    double previous = 0.0;
    for (float side : {0.25f, 0.5f, 1.0f}) {
        PenumbraSetup p;
        p.lightSide = side;
        const test::PenumbraWidths w = measure(p);
        SCOPED_TRACE("light side " + std::to_string(side));
        EXPECT_GT(w.technique, 1.5 * previous) << "doubling the light widens the penumbra";
        // A disk filter's 10-90 % ramp spans 0.63 of its diameter, a square light's 0.8
        // of the penumbra: PCSS's edge is 0.79 times the exact one where its estimate
        // w = (d_r - d_b) w_light / d_b is right, as it is here (one blocker depth).
        EXPECT_GT(w.technique, 0.6 * w.exact) << "exact " << w.exact;
        EXPECT_LT(w.technique, 1.1 * w.exact) << "exact " << w.exact;
        EXPECT_LT(w.rmse, 0.05) << "RMSE against the exact visibility";
        previous = w.technique;
    }
}

TEST_F(PcssPenumbra, WidthGrowsWithTheReceiverBlockerDistance)
{
    double previous = 0.0;
    for (float height : {0.5f, 1.0f, 1.5f}) {
        PenumbraSetup p;
        p.occluderHeight = height;
        const test::PenumbraWidths w = measure(p);
        SCOPED_TRACE("occluder height " + std::to_string(height));
        // w h / (H - h): 0.1, 0.25, 0.5 for w = 0.5.
        EXPECT_GT(w.technique, 1.5 * previous);
        EXPECT_GT(w.technique, 0.6 * w.exact) << "exact " << w.exact;
        EXPECT_LT(w.technique, 1.1 * w.exact) << "exact " << w.exact;
        previous = w.technique;
    }
}

TEST_F(PcssPenumbra, BlockerTouchingTheReceiverCastsAHardShadow)
{
    // At the box's foot the blockers are at the receiver: d_r - d_b -> 0, so the filter
    // shrinks to one texel's compare (contact hardening) and the ground right behind the
    // foot is umbra, with no division by zero; the penumbra widens away from the foot.
    const std::vector<float> v = renderWith(test::boxOnGroundConfig(), penumbraPcss(), test::boxOnGroundScene());
    const double texel = 2.0 * 3.0 / 1024.0;  // a texel of the cube face on the ground, at most
    const test::FootShadow foot = test::footShadow(*frame, v, texel, 0.0f);
    EXPECT_GT(foot.pixels, 100u);
    EXPECT_EQ(foot.notUmbra, 0u) << "ground pixels right behind the foot that are not umbra (V > 0)";
    // The side edge widens away from the foot. Less than the exact penumbra does (from
    // about 1 cm to 0.3 m here): the search also finds the box's top, far from the
    // ground, and the mean blocker distance mixes the two (Fernando 2005's single
    // average; measured 0.16 m at x = 0.6 and 0.23 m at x = 2).
    const double nearFoot = test::sideEdgeWidth(*frame, v, 0.6f), farFromFoot = test::sideEdgeWidth(*frame, v, 2.0f);
    EXPECT_LT(nearFoot, 0.85 * farFromFoot) << "near the foot " << nearFoot << ", far " << farFromFoot;
}

// ---------------------------------------------------------------------------------
// Guards.

TEST_F(PcssTest, NoBlockerIsExactlyLit)
{
    // A plane alone under a large directional light at 60 and 85 degrees from its normal
    // (85: grazing): the receiver plane keeps it from finding itself as a blocker, so
    // every pixel is exactly 1.
    for (float degrees : {60.0f, 85.0f}) {
        config::RenderConfig cfg = test::planeUnderDirectionalLightConfig(degrees);
        cfg.lights[0].light.angularDiameterDeg = 10.0f;
        const std::vector<float> v = renderWith(cfg, {}, test::planeScene());
        expectExactlyLitWhereGeometry(v, fmt::format("{} degrees", degrees));
    }
}

TEST_F(PcssTest, HugeLightIsClampedToTheMaximumRadii)
{
    // A spot light of 1e9 world units: the search and the filter stop at their maximum
    // radii, so penumbrae stay that narrow (agreement with the rays beyond them) and the
    // image is what a light of 1e3 gives, but where the receiver-blocker gap is so
    // small that 1e3 does not yet reach the maximum filter.
    config::RenderConfig cfg = test::defaultTestConfig();
    PcssSettings s;
    s.lightSize = 1e9;
    const std::vector<float> huge = renderWith(cfg, s);
    expectRayCastAgreement(huge, s, "light size 1e9");
    s.lightSize = 1e3;
    const std::vector<float> large = renderWith(cfg, s);
    size_t differ = 0;
    for (size_t i = 0; i < huge.size(); ++i) differ += huge[i] != large[i];
    EXPECT_LT(differ, huge.size() / 100);
}

TEST_F(PcssTest, BlockerAtTheLightIsClampedNotInfinite)
{
    // d_b -> 0: a 0.2 x 0.2 plate 1 mm under a point light 3 m above the ground, whose
    // shadow covers all the ground in view (seen from under the plate). (d_r - d_b) / d_b
    // is 3000: the radii stop at their maxima, every tap finds the plate, V = 0 exactly.
    scene::Scene s = test::planeScene();
    test::addInstance(s, test::addMesh(s, scene::makePlane("plate")), "plate",
                      glm::scale(glm::translate(glm::mat4(1.0f), {0.0f, 2.999f, 0.0f}), {0.2f, 1.0f, 0.2f}));
    config::RenderConfig cfg = test::boxOnGroundConfig();
    cfg.camera.position = {0.0f, 1.0f, 0.0f};
    cfg.camera.target = {0.0f, 0.0f, 0.0f};
    cfg.lights[0].light.type = scene::LightType::Point;
    cfg.lights[0].light.position = {0.0f, 3.0f, 0.0f};
    PcssSettings settings;
    settings.lightSize = 0.5;
    const std::vector<float> v = renderWith(cfg, settings, std::move(s));
    size_t ground = 0, lit = 0;
    for (size_t i = 0; i < v.size(); ++i) {
        if (!frame->onGround(i)) continue;
        ++ground;
        lit += v[i] != 0.0f;
    }
    EXPECT_GT(ground, v.size() / 2);
    EXPECT_EQ(lit, 0u) << "ground pixels not in the plate's umbra";
}

TEST_F(PcssTest, AngularDiameterBeyond180DegreesIsClamped)
{
    config::RenderConfig cfg = test::defaultTestConfig();
    test::setLightType(cfg.lights[0], scene::LightType::Directional);
    PcssSettings s;
    s.lightSize = 1e6;  // degrees
    renderWith(cfg, s);  // finite, in [0, 1] (expectValidVisibility)
}

// ---------------------------------------------------------------------------------
// Scene scale: distances enter only as ratios (d_r - d_b) / d_b, w_light / near, and
// texels, so the default scene at 1e-3 and 1e5 agrees with the rays as at 1.

namespace {

class PcssScales : public PcssTest, public ::testing::WithParamInterface<std::tuple<float, LightCase>> {};

} // namespace

TEST_P(PcssScales, MatchesRayCastAwayFromPenumbrae)
{
    const auto& [scale, c] = GetParam();
    config::RenderConfig cfg = test::defaultTestConfig();
    test::setLightType(cfg.lights[0], c.type);
    PcssSettings s;
    s.lightSize = c.lightSize * scale;
    test::scaleConfig(cfg, scale);
    const std::vector<float> v = renderWith(cfg, s);
    expectRayCastAgreement(v, s, c.name);
}

INSTANTIATE_TEST_SUITE_P(Pcss, PcssScales,
                         ::testing::Combine(::testing::Values(1e-3f, 1e5f),
                                            ::testing::Values(LightCase{"spot", scene::LightType::Spot, 0.6},
                                                              LightCase{"point", scene::LightType::Point, 0.4})),
                         [](const ::testing::TestParamInfo<std::tuple<float, LightCase>>& info) {
                             return std::string(std::get<0>(info.param) < 1.0f ? "milli_" : "e5_") +
                                    std::get<1>(info.param).name;
                         });

// ---------------------------------------------------------------------------------
// Parameters.

TEST(PcssPluginEntry, ReflectsEveryParameterWithItsDefault)
{
    plugin::PluginRegistry registry;
    const plugin::ParamValues params = registry.load("pcss").defaultParams();
    EXPECT_EQ(params.getInt("resolution"), 2048);
    EXPECT_EQ(params.getFloat("light_size"), -1.0f);
    EXPECT_EQ(params.getInt("blocker_samples"), 16);
    EXPECT_EQ(params.getInt("filter_samples"), 32);
    EXPECT_EQ(params.getFloat("max_search_radius"), 0.0625f);  // of the face's side
    EXPECT_EQ(params.getFloat("max_filter_radius"), 0.0625f);
    EXPECT_EQ(params.getEnum("bias_mode"), "receiver_plane");
    EXPECT_EQ(params.getFloat("depth_bias"), 4.0f);
    EXPECT_EQ(params.getFloat("slope_bias"), 2.0f);
    for (const plugin::ParamSpec& spec : params.specs()) EXPECT_NE(std::string(spec.doc), "") << spec.name;
}

TEST(PcssPluginEntry, OutOfRangeValuesNameTheParameter)
{
    test::expectRefusalsNameTheParameter("pcss", {{"blocker_samples", 65},
                                                  {"filter_samples", 3},
                                                  {"max_search_radius", 0.0},
                                                  {"max_filter_radius", 1e3},
                                                  {"light_size", -2.0},
                                                  {"bias_mode", "normal_offset"}});
}
