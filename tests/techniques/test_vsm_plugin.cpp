// The VSM family plugin (plugins/vsm) end to end, through frame::FrameRenderer: every
// variant on every light type against rays from the light, every filter and moment
// format, a lit receiver, the minimum variance guard, light-bleeding reduction on two
// stacked blockers, huge exponents at scene scales 1e-3 and 1e5, grazing light and a
// blocker touching its receiver.
#include "PluginFrame.h"
#include "RayCastAgreement.h"
#include "TestConfigs.h"
#include "TestContext.h"

#include "penumbra/config/Config.h"
#include "penumbra/core/Error.h"
#include "penumbra/plugin/PluginRegistry.h"

#include <gtest/gtest.h>

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>
#include <map>
#include <string>

using namespace penumbra;

namespace {

struct VsmSettings {
    std::string variant = "vsm";
    std::string filter = "gaussian";
    std::string format = "auto";
    int blurRadius = 2;
    int resolution = 1024;
    // Parameters left at the plugin's defaults unless given here.
    std::map<std::string, nlohmann::json> more;
};

void applyVsm(config::LightConfig& light, const VsmSettings& s)
{
    nlohmann::json params = {{"variant", s.variant},
                             {"filter", s.filter},
                             {"moment_format", s.format},
                             {"blur_radius", s.blurRadius},
                             {"resolution", s.resolution}};
    for (const auto& [name, value] : s.more) params[name] = value;
    test::setShadow(light, "vsm", params);
}

// How far from the receiver, in texels, the filtered value at a pixel gathers casters:
// the blur's radius (or a mip footprint) and the bilinear lookup's texel.
double reachTexels(const VsmSettings& s)
{
    if (s.filter == "gaussian" || s.filter == "box") return s.blurRadius + 1.0;
    return 16.0;  // mip levels: the tests' footprints stay below 8 texels (level 3), and 2x for trilinear
}

// The agreement tolerance of each variant in the default scene (largest errors measured
// with blur radius 2 over the five light types: vsm 0.034, evsm 0.008, esm 0.22 at 512
// texels; vsm 0.089, evsm 0.02, esm 0.26 at 1024). VSM bleeds where a shadowed
// receiver's filter also holds a second, nearer blocker; ESM's e^{-c (t - z)} stays above
// 0 where the receiver is close behind its blocker, as at the feet of the boxes (c = 80
// and a gap of 2 % of the depth range leave 0.2).
float tolerance(const std::string& variant)
{
    if (variant == "evsm") return 0.03f;
    if (variant == "esm") return 0.3f;
    return 0.1f;
}

class VsmTest : public test::TechniqueTest<VsmSettings, applyVsm> {
protected:
    // Against rays from the light: where every caster within the filter's reach is the
    // receiver itself (lit) or lies well in front of it (shadowed). The VSM family's
    // answer there is not exactly 0: Chebyshev's bound is an upper bound, so umbrae
    // keep some light where several blocker depths share the filter (bleeding), and
    // ESM's e^{c (z - t)} reaches 0 only as the gap grows. `tolerance` states how much.
    test::RayCastAgreement agreement(const std::vector<float>& v, const VsmSettings& s, float tolerance,
                                     const std::string& label)
    {
        return frame->rayCastAgreement(v, reachTexels(s) + 2.0, tolerance, label);
    }
};

// ---------------------------------------------------------------------------------
// Every variant on every light type.

using test::LightCase;

const LightCase kLights[] = {{"spot", scene::LightType::Spot},
                             {"directional", scene::LightType::Directional},
                             {"point", scene::LightType::Point},
                             {"rect", scene::LightType::Rect},
                             {"disk", scene::LightType::Disk}};

class VsmVariantsAndLights : public VsmTest,
                             public ::testing::WithParamInterface<std::tuple<const char*, LightCase>> {};

} // namespace

TEST_P(VsmVariantsAndLights, MatchesRayCastAwayFromShadowEdges)
{
    const auto& [variant, light] = GetParam();
    config::RenderConfig cfg = test::defaultTestConfig();
    test::setLightType(cfg.lights[0], light.type);
    VsmSettings s;
    s.variant = variant;
    // 512 texels keep the full-resolution passes over six cube faces quick; the
    // directional light's map spans the whole scene: twice the texels.
    s.resolution = light.type == scene::LightType::Directional ? 1024 : 512;
    const std::vector<float> v = renderWith(cfg, s);
    const test::RayCastAgreement a = agreement(v, s, tolerance(variant), std::string(variant) + " " + light.name);
    EXPECT_EQ(a.mismatches, 0u);
    EXPECT_GT(a.surelyShadowed, 150u);
    EXPECT_GT(a.surelyLit, 2000u);
}

INSTANTIATE_TEST_SUITE_P(Vsm, VsmVariantsAndLights,
                         ::testing::Combine(::testing::Values("vsm", "evsm", "esm"), ::testing::ValuesIn(kLights)),
                         [](const ::testing::TestParamInfo<std::tuple<const char*, LightCase>>& info) {
                             return std::string(std::get<0>(info.param)) + "_" + std::get<1>(info.param).name;
                         });

// ---------------------------------------------------------------------------------
// Every filter and every moment format.

namespace {

struct FilterCase {
    const char* name;
    const char* variant;
    const char* filter;
    const char* format;
    float tolerance;
};

std::ostream& operator<<(std::ostream& os, const FilterCase& c) { return os << c.name; }

class VsmFilters : public VsmTest, public ::testing::WithParamInterface<FilterCase> {};

} // namespace

TEST_P(VsmFilters, MatchesRayCastAwayFromShadowEdges)
{
    const FilterCase& c = GetParam();
    VsmSettings s;
    s.variant = c.variant;
    s.filter = c.filter;
    s.format = c.format;
    // The mip filters reach up to 16 texels at 1024 (reachTexels()): half the map would
    // double that in world units and leave few pixels clear of edges.
    s.resolution = s.filter == "gaussian" || s.filter == "box" ? 512 : 1024;
    if (s.format == "rgba16f") s.more["min_variance"] = 1e-4;  // VsmPlane.MinimumVarianceKeepsAFlatReceiverLit
    const std::vector<float> v = renderWith(test::defaultTestConfig(), s);
    const float allowed = c.tolerance;
    const test::RayCastAgreement a = agreement(v, s, allowed, c.name);
    EXPECT_EQ(a.mismatches, 0u);
    EXPECT_GT(a.surelyShadowed, 150u);
    EXPECT_GT(a.surelyLit, 2000u);
}

INSTANTIATE_TEST_SUITE_P(
    Vsm, VsmFilters,
    // Tolerances: the variants' (tolerance()), but VSM with half floats needs a larger
    // minimum variance, which lets more light through at small gaps (measured 0.13).
    // ESM in half floats loses up to c · 2^-12 of its exponent to rounding (lit
    // receivers measured down to 0.95), within its tolerance.
    ::testing::Values(FilterCase{"vsm_box", "vsm", "box", "auto", tolerance("vsm")},
                      FilterCase{"vsm_trilinear", "vsm", "trilinear", "auto", tolerance("vsm")},
                      FilterCase{"vsm_anisotropic", "vsm", "anisotropic", "auto", tolerance("vsm")},
                      FilterCase{"evsm_trilinear", "evsm", "trilinear", "auto", tolerance("evsm")},
                      FilterCase{"esm_anisotropic", "esm", "anisotropic", "auto", tolerance("esm")},
                      FilterCase{"vsm_rgba16f", "vsm", "gaussian", "rgba16f", 0.2f},
                      FilterCase{"evsm_rgba16f", "evsm", "gaussian", "rgba16f", tolerance("evsm")},
                      FilterCase{"esm_rgba16f", "esm", "gaussian", "rgba16f", tolerance("esm")},
                      FilterCase{"vsm_rgba32f", "vsm", "gaussian", "rgba32f", tolerance("vsm")},
                      FilterCase{"evsm2_rg32f", "evsm", "gaussian", "rg32f", tolerance("evsm")}),
    [](const ::testing::TestParamInfo<FilterCase>& info) { return std::string(info.param.name); });

// ---------------------------------------------------------------------------------
// A receiver with nothing in front of it, and the minimum variance.

namespace {

class VsmPlane : public VsmTest {
protected:
    // V on the plane's pixels.
    std::vector<float> planeVisibility(float degrees, const VsmSettings& s)
    {
        const std::vector<float> v = renderWith(test::planeUnderDirectionalLightConfig(degrees), s, test::planeScene());
        std::vector<float> plane;
        for (size_t i = 0; i < v.size(); ++i) {
            if (frame->hasGeometry(i)) plane.push_back(v[i]);
        }
        EXPECT_GT(plane.size(), v.size() / 2) << "the camera sees the plane";
        return plane;
    }
};

size_t countBelow(const std::vector<float>& v, float threshold)
{
    return size_t(std::count_if(v.begin(), v.end(), [&](float x) { return x < threshold; }));
}

} // namespace

TEST_F(VsmPlane, LitReceiverIsExactlyOne)
{
    // Nothing between the plane and the light, facing it or 40 degrees from it: VSM's
    // mean is the receiver's own depth (bilinear and blurred means of a linear depth are
    // exact up to rounding, which the minimum variance absorbs: 1 - (rounding / sigma)^2
    // rounds to 1 in fp32), ESM's E[e^{c (z - t)}] >= 1 on a plane (Jensen) and its
    // exponent is clamped at 0. EVSM's negative warp -e^{-c t} is concave, so on a
    // tilted plane its mean lies a second-order hair in front of the receiver: 1 within
    // 1e-4 there (measured 0.99996).
    for (const char* variant : {"vsm", "evsm", "esm"}) {
        for (float degrees : {0.0f, 40.0f}) {
            VsmSettings s;
            s.variant = variant;
            const std::vector<float> plane = planeVisibility(degrees, s);
            const float least = std::string(variant) == "evsm" && degrees > 0.0f ? 1.0f - 1e-4f : 1.0f;
            EXPECT_EQ(countBelow(plane, least), 0u) << variant << ", light " << degrees << " degrees from the normal";
        }
    }
}

TEST_F(VsmPlane, MinimumVarianceKeepsAFlatReceiverLit)
{
    // Half floats round t and t^2 to 11 bits: on a plane 40 degrees from the light the
    // filtered mean and E[t^2] - E[t]^2 are off by about 1e-3, often putting the receiver
    // behind the mean with no variance left, and a variance of 0 then gives p_max = 0
    // (5 % of the plane). The minimum variance is the guard; rgba16f needs 1e-4 (README).
    VsmSettings s;
    s.format = "rgba16f";
    s.more["min_variance"] = 0.0;
    s.more["bleeding_reduction"] = 0.0;
    const std::vector<float> unguarded = planeVisibility(40.0f, s);
    EXPECT_GT(countBelow(unguarded, 0.5f), unguarded.size() / 100) << "without a minimum variance";
    s.more["min_variance"] = 1e-4;
    EXPECT_EQ(countBelow(planeVisibility(40.0f, s), 0.99f), 0u) << "with a minimum variance of 1e-4";
}

TEST_F(VsmPlane, GrazingLightGivesNoNaN)
{
    // 85 and 89 degrees from the normal: depth changes by tan(89°) = 57 texels of depth
    // per texel; no NaN, V in [0, 1] (checkedVisibility), and the lit plane stays lit
    // within the blur's reach of its own depth slope.
    for (const char* variant : {"vsm", "evsm", "esm"}) {
        for (float degrees : {85.0f, 89.0f}) {
            VsmSettings s;
            s.variant = variant;
            const std::vector<float> plane = planeVisibility(degrees, s);
            EXPECT_LT(countBelow(plane, 0.9f), plane.size() / 100) << variant << ", " << degrees << " degrees";
        }
    }
}

// ---------------------------------------------------------------------------------
// Light bleeding: two plates stacked over the ground, lit from straight above. The
// lower one (4 x 4 at height 1.5) shadows all the ground in view; the upper one (2 x 2
// at height 3) ends above x = 0. Where the filter holds both plates' depths (t near 0
// and 0.5), their variance is large and Chebyshev's bound for the ground (t near 1) is
// about sigma^2 / (sigma^2 + (1 - mu)^2) = 0.1: light where there is none.

namespace {

scene::Scene stackedPlatesScene()
{
    scene::Scene s = test::planeScene();
    scene::Mesh plate = scene::makePlane("plate");
    plate.computeBounds();
    s.meshes.push_back(plate);
    const glm::mat4 identity(1.0f);
    s.addInstance(1, s.graph.addNode("upper", scene::kNoParent,
                                     glm::scale(glm::translate(identity, {-1.0f, 3.0f, 0.0f}), {2.0f, 1.0f, 2.0f})));
    s.addInstance(1, s.graph.addNode("lower", scene::kNoParent,
                                     glm::scale(glm::translate(identity, {0.0f, 1.5f, 0.0f}), {4.0f, 1.0f, 4.0f})));
    return s;
}

// The camera under the lower plate looks down on the ground around x = 0.
config::RenderConfig stackedPlatesConfig()
{
    config::RenderConfig cfg = test::defaultTestConfig();
    cfg.camera.position = {0.0f, 1.0f, 0.0f};
    cfg.camera.target = {0.0f, 0.0f, 0.0f};
    cfg.camera.up = {0.0f, 0.0f, -1.0f};
    cfg.camera.fovYDeg = 60.0f;
    cfg.camera.nearWorld = 0.01f;
    cfg.lights.resize(1);
    cfg.lights[0].light = {};
    cfg.lights[0].light.type = scene::LightType::Directional;
    cfg.lights[0].light.direction = {0.0f, -1.0f, 0.0f};
    return cfg;
}

class VsmBleeding : public VsmTest {
protected:
    // The largest V on the ground, all of which the lower plate shadows.
    float brightestGround(const std::string& variant, double reduction)
    {
        VsmSettings s;
        s.variant = variant;
        s.blurRadius = 4;
        s.more["bleeding_reduction"] = reduction;
        const std::vector<float> v = renderWith(stackedPlatesConfig(), s, stackedPlatesScene());
        float brightest = 0.0f;
        size_t ground = 0;
        for (size_t i = 0; i < v.size(); ++i) {
            if (!frame->onGround(i)) continue;
            ++ground;
            brightest = std::max(brightest, v[i]);
        }
        EXPECT_GT(ground, v.size() / 2) << "the camera sees the ground";
        return brightest;
    }
};

} // namespace

TEST_F(VsmBleeding, ReductionRemovesTheLightThatBleedsUnderTwoBlockers)
{
    // Measured: 0.11 without reduction, 0 with 0.2, EVSM 0.006 without.
    const float bleeding = brightestGround("vsm", 0.0);
    EXPECT_GT(bleeding, 0.05f) << "the premise: plain VSM bleeds here";
    EXPECT_LT(brightestGround("vsm", 0.2), 0.1f * bleeding) << "bleeding_reduction 0.2";
    // EVSM's exponential warp separates the two plates far more than their depths do.
    EXPECT_LT(brightestGround("evsm", 0.0), 0.1f * bleeding) << "evsm without reduction";
}

// ---------------------------------------------------------------------------------
// Huge exponents, both storage precisions, and scene scales 1e-3 and 1e5: EVSM's are
// clamped (42 in fp32, 5.54 in fp16), ESM filters in log space; depths are normalised
// over the scene's depth range, so the scale changes nothing.

namespace {

struct ExtremeCase {
    const char* variant;
    const char* format;
    float scale;
};

std::ostream& operator<<(std::ostream& os, const ExtremeCase& c)
{
    return os << c.variant << " " << c.format << " at scale " << c.scale;
}

class VsmExtremes : public VsmTest, public ::testing::WithParamInterface<ExtremeCase> {};

} // namespace

TEST_P(VsmExtremes, HugeExponentsStayFiniteAtEveryScale)
{
    const ExtremeCase& c = GetParam();
    config::RenderConfig cfg = test::defaultTestConfig();
    test::scaleConfig(cfg, c.scale);
    VsmSettings s;
    s.variant = c.variant;
    s.format = c.format;
    s.more["positive_exponent"] = 1e4;
    s.more["negative_exponent"] = 1e4;
    s.more["esm_exponent"] = 1e4;
    const std::vector<float> v = renderWith(cfg, s);  // finite, in [0, 1]: checkedVisibility
    // ESM with c = 1e4 (single floats) is a hard test against the largest depth under
    // the filter: lit exactly where any texel within the blur is at or behind the
    // receiver, so its shadows shrink by the blur's reach (inside the band); half floats
    // clamp c to 200. EVSM at its clamp leaves tilted lit receivers a little dark: its
    // negative warp -e^{-c t} is concave, and the mean over a blur that spans a depth
    // variance var_t lies in front of the receiver by about c^2 var_t of the warped
    // variance (measured 0.05 on the boxes' sides at c = 42).
    float allowed = tolerance(c.variant);
    if (std::string(c.variant) == "esm" && std::string(c.format) != "rgba16f") allowed = 1e-3f;
    if (std::string(c.variant) == "evsm") allowed = 0.1f;
    const test::RayCastAgreement a = agreement(v, s, allowed, std::string(c.variant) + " " + c.format);
    EXPECT_EQ(a.mismatches, 0u);
    EXPECT_GT(a.surelyShadowed, 150u);
    EXPECT_GT(a.surelyLit, 2000u);
}

INSTANTIATE_TEST_SUITE_P(Vsm, VsmExtremes,
                         ::testing::Values(ExtremeCase{"evsm", "rgba32f", 1e-3f}, ExtremeCase{"evsm", "rgba16f", 1e5f},
                                           ExtremeCase{"esm", "rg32f", 1e5f}, ExtremeCase{"esm", "rgba16f", 1e-3f}),
                         [](const ::testing::TestParamInfo<ExtremeCase>& info) {
                             return std::string(info.param.variant) + "_" + info.param.format +
                                    (info.param.scale < 1.0f ? "_milli" : "_e5");
                         });

// ---------------------------------------------------------------------------------
// A blocker touching its receiver: the box standing on the ground. No NaN at the
// contact; right behind the foot the receiver is a hair behind the blocker, where every
// variant leaks (the README's trade-off), but the shadow is there.

TEST_F(VsmTest, BlockerTouchingTheReceiverGivesAShadowWithoutNaN)
{
    for (const char* variant : {"vsm", "evsm", "esm"}) {
        VsmSettings s;
        s.variant = variant;
        const std::vector<float> v = renderWith(test::boxOnGroundConfig(), s, test::boxOnGroundScene());
        double nearFoot = 0.0, farther = 0.0;
        size_t nearCount = 0, fartherCount = 0;
        for (size_t i = 0; i < v.size(); ++i) {
            const glm::vec3 q = frame->position(i);
            if (!frame->onGround(i) || std::abs(q.z) > 0.3f) continue;
            if (q.x > 0.52f && q.x < 0.7f) nearFoot += v[i], ++nearCount;
            if (q.x > 1.2f && q.x < 1.8f) farther += v[i], ++fartherCount;
        }
        ASSERT_GT(nearCount, 100u);
        ASSERT_GT(fartherCount, 100u);
        EXPECT_LT(nearFoot / nearCount, 0.5) << variant << ": mean V on the ground right behind the foot";
        EXPECT_LT(farther / fartherCount, 0.05) << variant << ": mean V in the shadow farther from the foot";
    }
}

// ---------------------------------------------------------------------------------
// Parameters.

TEST(VsmPluginEntry, ReflectsEveryParameterWithItsDefault)
{
    plugin::PluginRegistry registry;
    const plugin::ParamValues params = registry.load("vsm").defaultParams();
    EXPECT_EQ(params.getInt("resolution"), 1024);
    EXPECT_EQ(params.getEnum("variant"), "vsm");
    EXPECT_EQ(params.getEnum("moment_format"), "auto");
    EXPECT_EQ(params.getEnum("filter"), "gaussian");
    EXPECT_EQ(params.getInt("blur_radius"), 2);
    EXPECT_EQ(params.getFloat("min_variance"), 1e-6f);
    EXPECT_EQ(params.getFloat("bleeding_reduction"), 0.2f);
    EXPECT_EQ(params.getFloat("positive_exponent"), 40.0f);
    EXPECT_EQ(params.getFloat("negative_exponent"), 5.0f);
    EXPECT_EQ(params.getFloat("esm_exponent"), 80.0f);
    for (const plugin::ParamSpec& spec : params.specs()) EXPECT_NE(std::string(spec.doc), "") << spec.name;
}

TEST(VsmPluginEntry, OutOfRangeValuesNameTheParameter)
{
    test::expectRefusalsNameTheParameter("vsm", {{"bleeding_reduction", 1.0},
                                                 {"min_variance", -1e-6},
                                                 {"blur_radius", 33},
                                                 {"variant", "pcf"},
                                                 {"moment_format", "r16f"},
                                                 {"max_anisotropy", 0}});
}

TEST_F(VsmTest, MipFiltersNeedAPowerOfTwoResolution)
{
    config::RenderConfig cfg = test::defaultTestConfig();
    VsmSettings s;
    s.filter = "trilinear";
    s.resolution = 1000;
    try {
        renderWith(cfg, s);
        FAIL() << "rendered with resolution 1000 and a mip filter";
    } catch (const Error& e) {
        const std::string what = e.what();
        EXPECT_NE(what.find("resolution"), std::string::npos) << what;
        EXPECT_NE(what.find("1024"), std::string::npos) << what;
    }
}
