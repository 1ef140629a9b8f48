// The hard shadow plugin (plugins/hard) end to end: each bias mode and filter rendered
// through the engine's plugin path and checked against rays from the light, acne on a
// grazing receiver, how far filters spread, and parameter errors.
//
// ---------------------------------------------------------------------------------
// BUILT ONLY WITH -DPENUMBRA_TEST_HARD_PLUGIN=ON (tests/CMakeLists.txt). It is written
// against the renderer of the technique-plugin integration:
//   frame::FrameRenderer(gpu::Context&, const scene::Scene&, const config::RenderConfig&,
//                         plugin::PluginRegistry&)
// with renderFrame(), readVisibility(l), readPositions() and readNormals(), and against
// plugin::PluginRegistry and plugin::ParamValues as engine/include/penumbra/plugin/
// declares them. Turn the option on (or list the file in penumbra_tests) once
// FrameRenderer runs technique plugins through the render graph.
// ---------------------------------------------------------------------------------
#include "PluginFrame.h"
#include "RayCastAgreement.h"
#include "TestConfigs.h"
#include "TestContext.h"

#include "penumbra/config/Config.h"
#include "penumbra/core/Error.h"
#include "penumbra/frame/FrameRenderer.h"
#include "penumbra/gpu/ShaderCompiler.h"
#include "penumbra/plugin/PluginRegistry.h"
#include "penumbra/render/Casters.h"
#include "penumbra/render/Projection.h"
#include "penumbra/render/SceneGpu.h"
#include "penumbra/scene/Generators.h"

#include <gtest/gtest.h>

#include <glm/gtc/matrix_transform.hpp>

#include <cmath>
#include <memory>
#include <string>
#include <tuple>

using namespace penumbra;
using test::kBinaryTolerance;

namespace {

bool fractional(float v) { return v > kBinaryTolerance && v < 1.0f - kBinaryTolerance; }

// The plugin's parameters as a test sets them; the defaults are the plugin's.
struct HardSettings {
    std::string biasMode = "slope";
    std::string filter = "none";
    int pcfKernel = 3;
    int poissonSamples = 16;
    double filterRadius = 1.5;
    double depthBias = 4.0;
    double normalOffset = 1.0;
    int resolution = 2048;
};

void applySettings(config::LightConfig& light, const HardSettings& s)
{
    config::ShadowSettings& shadow = light.shadow;
    shadow.technique = "hard";
    shadow.required = true;  // a plugin that fails must fail the test, not render unshadowed
    shadow.setParam("bias_mode", s.biasMode, "test");
    shadow.setParam("filter", s.filter, "test");
    shadow.setParam("pcf_kernel", s.pcfKernel, "test");
    shadow.setParam("poisson_samples", s.poissonSamples, "test");
    shadow.setParam("filter_radius", s.filterRadius, "test");
    shadow.setParam("depth_bias", s.depthBias, "test");
    shadow.setParam("normal_offset", s.normalOffset, "test");
    shadow.setParam("resolution", s.resolution, "test");
}

// How far from the receiver, in shadow-map texels, a variant's compares reach: its
// farthest tap plus half a texel's diagonal (a nearest tap reads the texel it falls in).
double footprintTexels(const HardSettings& s)
{
    const double nearest = std::sqrt(0.5);
    if (s.filter == "pcf") return 0.5 * (s.pcfKernel - 1) * std::sqrt(2.0) + nearest;
    if (s.filter == "poisson") return s.filterRadius + nearest;
    if (s.filter == "bilinear") return std::sqrt(2.0);  // the far corner of the 2 x 2 footprint
    return nearest;
}

// The filter's width in texels, by which the plugin scales slope_bias and normal_offset
// (plugins/hard/README.md).
double filterWidthTexels(const HardSettings& s)
{
    if (s.filter == "pcf") return s.pcfKernel;
    if (s.filter == "poisson") return 2.0 * s.filterRadius + 1.0;
    if (s.filter == "bilinear") return 2.0;
    return 1.0;
}

// How far a variant's bias may move a shadow edge, in texels. A slope-scaled bias of
// S = slope_bias × width pushes a caster back by as much depth as S texels of its own
// slope: the shadow of a wall starts up to S texels from its foot (peter-panning). The
// normal offset moves the lookup point by up to normal_offset × width texels. Receiver
// plane bias moves nothing. (Constant bias: see its variant.)
double edgeShiftTexels(const HardSettings& s)
{
    if (s.biasMode == "slope") return 2.0 * filterWidthTexels(s);  // the default slope_bias, 2
    if (s.biasMode == "normal_offset") return s.normalOffset * filterWidthTexels(s);
    return 0.0;
}

using test::PluginGpuTest;

// ---------------------------------------------------------------------------------
// Each variant in the default scene.

struct Variant {
    const char* name;
    scene::LightType light;
    HardSettings settings;
    double extraEdgeShiftTexels = 0.0;  // beyond edgeShiftTexels(settings)

    // Pixels this far from an edge in the light's view are left out of the ray-cast
    // comparison: what the taps reach, how far the bias moves edges, and the two texels
    // test_render.cpp allows the hard shadow.
    double edgeBandTexels() const
    {
        return footprintTexels(settings) + edgeShiftTexels(settings) + extraEdgeShiftTexels + 2.0;
    }
};

std::ostream& operator<<(std::ostream& os, const Variant& v) { return os << v.name; }

// Every filter with the default (slope) bias, every bias mode without a filter, then
// the combinations that exercise code of their own: receiver plane with each filter
// (per-tap depths; bilinear by hand), and the cube atlas (point light: taps clamped
// to their face) and the orthographic map (directional light).
HardSettings with(std::string biasMode, std::string filter)
{
    HardSettings s;
    s.biasMode = std::move(biasMode);
    s.filter = std::move(filter);
    return s;
}

// Constant bias alone must cover the steepest lit receiver (N.L = 0.1, 84 degrees: about
// 0.7 · tan 84° ≈ 7 texels of depth along the light) and then detaches every shadow from
// its caster. In the directional light's orthographic map (depth linear in distance,
// r = 2^-25 .. 2^-24 for depths 0.25 .. 1) 5e4 r is 3 to 6 texels of depth; edges on the
// ground move by up to ~15 texels.
HardSettings constantBiasForSteepReceivers()
{
    HardSettings s = with("constant", "none");
    s.depthBias = 5e4;
    return s;
}

const Variant kVariants[] = {
    {"slope_none", scene::LightType::Spot, with("slope", "none")},
    {"slope_pcf", scene::LightType::Spot, with("slope", "pcf")},
    {"slope_poisson", scene::LightType::Spot, with("slope", "poisson")},
    {"slope_bilinear", scene::LightType::Spot, with("slope", "bilinear")},
    {"constant_none", scene::LightType::Directional, constantBiasForSteepReceivers(), 15.0},
    {"normal_offset_none", scene::LightType::Spot, with("normal_offset", "none")},
    {"receiver_plane_none", scene::LightType::Spot, with("receiver_plane", "none")},
    {"receiver_plane_pcf", scene::LightType::Spot, with("receiver_plane", "pcf")},
    {"receiver_plane_poisson", scene::LightType::Spot, with("receiver_plane", "poisson")},
    {"receiver_plane_bilinear", scene::LightType::Spot, with("receiver_plane", "bilinear")},
    {"normal_offset_pcf", scene::LightType::Spot, with("normal_offset", "pcf")},
    {"point_slope_pcf", scene::LightType::Point, with("slope", "pcf")},
    {"point_receiver_plane_poisson", scene::LightType::Point, with("receiver_plane", "poisson")},
    {"point_normal_offset_bilinear", scene::LightType::Point, with("normal_offset", "bilinear")},
    {"directional_receiver_plane_pcf", scene::LightType::Directional, with("receiver_plane", "pcf")},
    {"directional_normal_offset_poisson", scene::LightType::Directional, with("normal_offset", "poisson")},
};

class HardVariants : public PluginGpuTest, public ::testing::WithParamInterface<Variant> {
protected:
    void SetUp() override
    {
        PluginGpuTest::SetUp();
        config::RenderConfig cfg = test::defaultTestConfig();
        test::setLightType(cfg.lights[0], GetParam().light);
        applySettings(cfg.lights[0], GetParam().settings);
        render(cfg, config::buildScene(cfg.scene));
        visibility = frame->renderer.readVisibility(0);
    }

    std::vector<float> visibility;
};

} // namespace

TEST_P(HardVariants, VisibilityIsFiniteInUnitRangeAndLitWithoutGeometry)
{
    ASSERT_EQ(visibility.size(), size_t(frame->config.width) * frame->config.height);
    size_t shadowed = 0;
    for (size_t i = 0; i < visibility.size(); ++i) {
        const float v = visibility[i];
        ASSERT_TRUE(std::isfinite(v)) << "pixel " << i;
        ASSERT_GE(v, 0.0f) << "pixel " << i;
        ASSERT_LE(v, 1.0f) << "pixel " << i;
        if (!frame->hasGeometry(i)) {
            ASSERT_EQ(v, 1.0f) << "background pixel " << i;
        }
        shadowed += v < 0.5f;
    }
    EXPECT_GT(shadowed, visibility.size() / 50);
}

TEST_P(HardVariants, MatchesRayCastAwayFromShadowEdges)
{
    // As test_render.cpp requires of the hard shadow: no pixel wrong that is clear of
    // edges in the light's view (Variant::edgeBandTexels).
    const test::FrameImages images{frame->positions, frame->normals, visibility, frame->config.width,
                                   frame->config.height};
    const test::RayCastAgreement a = test::compareWithRayCast(
        frame->classifier(0), images, {2, GetParam().edgeBandTexels(), kBinaryTolerance, GetParam().name});
    EXPECT_EQ(a.mismatches, 0u);
    // Enough of both classes that the comparison means something (wide bands leave
    // fewer shadowed pixels than test_render.cpp's 500).
    EXPECT_GT(a.surelyShadowed, 150u);
    EXPECT_GT(a.surelyLit, 2000u);
}

TEST_P(HardVariants, FractionalVisibilityOnlyNearShadowEdges)
{
    // Filters make penumbrae a footprint wide; anywhere else V stays 0 or 1. The band a
    // fractional pixel must lie in: two footprints from an edge as seen from the light,
    // plus what the bias moves edges by and two texels.
    const HardSettings& s = GetParam().settings;
    const double band = GetParam().edgeBandTexels() + footprintTexels(s);
    const test::LightRayClassifier classifier = frame->classifier(0);
    size_t fractionalPixels = 0, farFromEdges = 0;
    for (size_t i = 0; i < visibility.size(); ++i) {
        if (!fractional(visibility[i])) continue;
        ++fractionalPixels;
        const float* p = &frame->positions[4 * i];
        const float* n = &frame->normals[4 * i];
        const test::RayClass c = classifier.classify({p[0], p[1], p[2]}, {n[0], n[1], n[2]}, band);
        if ((c == test::RayClass::Lit || c == test::RayClass::Shadowed) && ++farFromEdges <= 10) {
            ADD_FAILURE() << "pixel (" << i % frame->config.width << ", " << i / frame->config.width << ") V = "
                          << visibility[i] << " but rays say " << (c == test::RayClass::Lit ? "lit" : "shadowed")
                          << " everywhere within " << band << " texels";
        }
    }
    EXPECT_EQ(farFromEdges, 0u);
    if (s.filter == "none") {
        EXPECT_EQ(fractionalPixels, 0u) << "one compare per pixel gives V = 0 or 1";
    } else {
        // Bilinear blends one texel: the narrowest band, on lit faces only (faces turned
        // away from the light hold 0 whatever the map says).
        EXPECT_GT(fractionalPixels, s.filter == "bilinear" ? 50u : 100u) << "a filter softens the shadow edges";
    }
}

INSTANTIATE_TEST_SUITE_P(Hard, HardVariants, ::testing::ValuesIn(kVariants),
                         [](const ::testing::TestParamInfo<Variant>& info) { return std::string(info.param.name); });

// ---------------------------------------------------------------------------------
// Scene scale: the receiver-side biases work in texels and the map's own depth, so the
// default scene at a thousandth and at 10^5 of its size must agree with the rays as
// well as at 1 (test_render.cpp's scale extremes).

class HardScales : public PluginGpuTest, public ::testing::WithParamInterface<std::tuple<float, Variant>> {};

TEST_P(HardScales, MatchesRayCastAwayFromShadowEdges)
{
    const auto& [scale, variant] = GetParam();
    config::RenderConfig cfg = test::defaultTestConfig();
    test::setLightType(cfg.lights[0], variant.light);
    applySettings(cfg.lights[0], variant.settings);
    test::scaleConfig(cfg, scale);
    render(cfg, config::buildScene(cfg.scene));
    const std::vector<float> visibility = frame->renderer.readVisibility(0);
    for (float v : visibility) ASSERT_TRUE(std::isfinite(v) && v >= 0.0f && v <= 1.0f) << v;
    const test::FrameImages images{frame->positions, frame->normals, visibility, cfg.width, cfg.height};
    const test::RayCastAgreement a = test::compareWithRayCast(
        frame->classifier(0), images, {2, variant.edgeBandTexels(), kBinaryTolerance, variant.name});
    EXPECT_EQ(a.mismatches, 0u);
    EXPECT_GT(a.surelyShadowed, 150u);
    EXPECT_GT(a.surelyLit, 2000u);
}

INSTANTIATE_TEST_SUITE_P(
    Hard, HardScales,
    ::testing::Combine(::testing::Values(1e-3f, 1e5f),
                       ::testing::Values(Variant{"normal_offset_poisson", scene::LightType::Spot,
                                                 with("normal_offset", "poisson")},
                                         Variant{"receiver_plane_pcf", scene::LightType::Spot,
                                                 with("receiver_plane", "pcf")},
                                         Variant{"point_receiver_plane_bilinear", scene::LightType::Point,
                                                 with("receiver_plane", "bilinear")})),
    [](const ::testing::TestParamInfo<std::tuple<float, Variant>>& info) {
        return std::string(std::get<0>(info.param) < 1.0f ? "milli_" : "e5_") + std::get<1>(info.param).name;
    });

// ---------------------------------------------------------------------------------
// Filter width.

class HardPcf : public PluginGpuTest {};

TEST_F(HardPcf, FractionalPixelsGrowWithTheKernel)
{
    size_t previous = 0;
    for (int kernel : {1, 3, 7, 15}) {
        config::RenderConfig cfg = test::defaultTestConfig();
        HardSettings s;
        s.filter = "pcf";
        s.pcfKernel = kernel;
        applySettings(cfg.lights[0], s);
        render(cfg, config::buildScene(cfg.scene));
        size_t count = 0;
        for (float v : frame->renderer.readVisibility(0)) count += fractional(v);
        if (kernel == 1) {
            EXPECT_EQ(count, 0u) << "a 1 x 1 kernel is one compare";
        } else {
            EXPECT_GT(count, previous) << "pcf_kernel " << kernel;
        }
        previous = count;
    }
}

// ---------------------------------------------------------------------------------
// Acne: a receiver at a grazing angle to the light, nothing casting onto it.

namespace {

class HardAcne : public PluginGpuTest, public ::testing::WithParamInterface<float> {
protected:
    // A 20 x 20 plane alone, seen from above, lit by a directional light GetParam()
    // degrees from its normal. Every pixel that sees the plane is lit.
    config::RenderConfig grazingConfig(const HardSettings& s) const
    {
        config::RenderConfig cfg = test::planeUnderDirectionalLightConfig(GetParam());
        cfg.lights[0].light.intensity = 3.0f;
        cfg.lights[0].shadow = {};
        applySettings(cfg.lights[0], s);
        return cfg;
    }

    // Fraction of the plane's pixels that are not fully lit.
    double unlitFraction(const HardSettings& s)
    {
        render(grazingConfig(s), test::planeScene());
        const std::vector<float> v = frame->renderer.readVisibility(0);
        size_t plane = 0, unlit = 0;
        for (size_t i = 0; i < v.size(); ++i) {
            if (!frame->hasGeometry(i)) continue;
            ++plane;
            unlit += v[i] < 1.0f - kBinaryTolerance;
        }
        EXPECT_GT(plane, v.size() / 2) << "the camera sees the plane";
        return plane ? double(unlit) / double(plane) : 1.0;
    }

    static HardSettings withoutDepthBias(std::string biasMode, std::string filter = "none")
    {
        HardSettings s = with(std::move(biasMode), std::move(filter));
        s.depthBias = 0.0;
        return s;
    }
};

} // namespace

TEST_P(HardAcne, ConstantBiasOfZeroShowsAcne)
{
    // The premise of the next tests: without bias a lit plane shadows itself in a
    // pattern of unlit texels.
    EXPECT_GT(unlitFraction(withoutDepthBias("constant")), 0.10);
}

TEST_P(HardAcne, SlopeScaledBiasRemovesAcne)
{
    // The rasterizer's slope term, scaled by the filter's width for wider filters.
    EXPECT_LT(unlitFraction(withoutDepthBias("slope")), 0.005);
    HardSettings pcf = withoutDepthBias("slope", "pcf");
    pcf.pcfKernel = 7;
    EXPECT_LT(unlitFraction(pcf), 0.005) << "pcf 7";
}

TEST_P(HardAcne, NormalOffsetRemovesAcne)
{
    EXPECT_LT(unlitFraction(withoutDepthBias("normal_offset")), 0.005);
    // The offset grows with the filter's width.
    HardSettings pcf = withoutDepthBias("normal_offset", "pcf");
    pcf.pcfKernel = 7;
    EXPECT_LT(unlitFraction(pcf), 0.005) << "pcf 7";
    HardSettings poisson = withoutDepthBias("normal_offset", "poisson");
    poisson.filterRadius = 4.0;
    EXPECT_LT(unlitFraction(poisson), 0.005) << "poisson, radius 4";
}

TEST_P(HardAcne, ReceiverPlaneRemovesAcne)
{
    EXPECT_LT(unlitFraction(withoutDepthBias("receiver_plane")), 0.005);
}

TEST_P(HardAcne, ReceiverPlaneRemovesAcneUnderWideFilters)
{
    // Each tap compares against the plane's own depth at that tap: any radius is clean.
    HardSettings pcf = withoutDepthBias("receiver_plane", "pcf");
    pcf.pcfKernel = 7;
    EXPECT_LT(unlitFraction(pcf), 0.005) << "pcf 7";
    HardSettings poisson = withoutDepthBias("receiver_plane", "poisson");
    poisson.filterRadius = 4.0;
    EXPECT_LT(unlitFraction(poisson), 0.005) << "poisson, radius 4";
    EXPECT_LT(unlitFraction(withoutDepthBias("receiver_plane", "bilinear")), 0.005) << "bilinear";
}

INSTANTIATE_TEST_SUITE_P(Hard, HardAcne, ::testing::Values(80.0f, 85.0f),
                         [](const ::testing::TestParamInfo<float>& info) {
                             return "deg" + std::to_string(int(info.param));
                         });

// ---------------------------------------------------------------------------------
// Alpha-masked casters cut holes in the map (the masked depth pipeline), whatever the
// bias mode.

class HardMasked : public PluginGpuTest, public ::testing::WithParamInterface<const char*> {};

TEST_P(HardMasked, LightPassesThroughTheHolesOnly)
{
    config::RenderConfig cfg = test::halfMaskedQuadConfig();
    HardSettings s = with(GetParam(), "none");
    s.resolution = 1024;
    applySettings(cfg.lights[0], s);
    render(cfg, test::halfMaskedQuadScene());
    const std::vector<float> v = frame->renderer.readVisibility(0);
    size_t throughHole = 0, inShadow = 0;
    for (size_t i = 0; i < v.size(); ++i) {
        const float x = frame->positions[4 * i], z = frame->positions[4 * i + 2];
        if (!frame->hasGeometry(i) || std::abs(z) > 1.5f) continue;
        if (x > -0.8f && x < -0.2f) {
            ASSERT_EQ(v[i], 1.0f) << "light passes through the hole onto x = " << x;
            ++throughHole;
        } else if (x > 2.2f && x < 2.8f) {
            ASSERT_EQ(v[i], 0.0f) << "the opaque half shadows the ground at x = " << x;
            ++inShadow;
        }
    }
    EXPECT_GT(throughHole, 50u);
    EXPECT_GT(inShadow, 100u);
}

// Constant bias is left out: its default (4 r) leaves acne on the slanted ground.
INSTANTIATE_TEST_SUITE_P(Hard, HardMasked, ::testing::Values("slope", "normal_offset", "receiver_plane"));

// ---------------------------------------------------------------------------------
// Parameters: reflection and errors.

TEST(HardPluginEntry, ReflectsEveryParameterWithItsDefault)
{
    plugin::PluginRegistry registry;
    const plugin::LoadedPlugin& hard = registry.load("hard");
    EXPECT_EQ(hard.name(), "hard");
    const plugin::ParamValues params = hard.defaultParams();
    // The first four are the names shipped configs use.
    EXPECT_EQ(params.getInt("resolution"), 2048);
    EXPECT_EQ(params.getFloat("depth_bias"), 4.0f);
    EXPECT_EQ(params.getFloat("slope_bias"), 2.0f);
    EXPECT_EQ(params.getFloat("bias_clamp"), 0.0f);
    EXPECT_EQ(params.getEnum("bias_mode"), "slope");
    EXPECT_EQ(params.getFloat("normal_offset"), 1.0f);
    EXPECT_EQ(params.getEnum("filter"), "none");
    EXPECT_EQ(params.getInt("pcf_kernel"), 3);
    EXPECT_EQ(params.getInt("poisson_samples"), 16);
    EXPECT_EQ(params.getFloat("filter_radius"), 1.5f);
    std::vector<std::string> names;
    for (const plugin::ParamSpec& spec : params.specs()) {
        names.push_back(spec.name);
        EXPECT_NE(std::string(spec.doc), "") << spec.name;
    }
    EXPECT_EQ(names, (std::vector<std::string>{"resolution", "depth_bias", "slope_bias", "bias_clamp", "bias_mode",
                                               "normal_offset", "filter", "pcf_kernel", "poisson_samples",
                                               "filter_radius"}));
}

TEST(HardPluginEntry, OutOfRangeValuesAndUnknownChoicesNameTheParameter)
{
    test::expectRefusalsNameTheParameter("hard", {{"pcf_kernel", 17},
                                                  {"poisson_samples", 3},
                                                  {"filter_radius", 0.25},
                                                  {"filter", "gaussian"},
                                                  {"bias_mode", "adaptive"}});
}

class HardPluginErrors : public PluginGpuTest {
protected:
    // Creates the technique through the registry, as the engine does for light 0.
    void create(const plugin::ParamValues& params, const config::RenderConfig& cfg)
    {
        const plugin::LoadedPlugin& hard = registry->load("hard");
        const scene::Scene scene = config::buildScene(cfg.scene);
        const render::SceneGpu sceneGpu(*context, scene);
        const render::Casters casters(sceneGpu);
        const gpu::ShaderCompiler shaders({hard.shaderDir, gpu::engineShaderDir()});
        const plugin::TechniqueSetup setup{*context,           shaders,        casters, scene,     params,
                                           cfg.lights[0].light, scene.bounds(), 0,       cfg.width, cfg.height,
                                           "light0.hard."};
        registry->create(hard, setup, "light 0");
    }

    std::string creationError(const plugin::ParamValues& params, const config::RenderConfig& cfg)
    {
        try {
            create(params, cfg);
        } catch (const plugin::PluginError& e) {
            EXPECT_EQ(e.kind(), plugin::PluginErrorKind::RegistrationFailed);
            return e.what();
        }
        ADD_FAILURE() << "the technique was created";
        return {};
    }
};

// The map's layout (face count, texels per face, light type) is compiled into the
// technique's shaders (render::ShadowMap::shaderDefines): a light that comes back as
// another type is refused by name, never looked up as the first.
TEST_F(HardPluginErrors, ALightThatChangesTypeIsRefusedNamingBothTypes)
{
    const plugin::LoadedPlugin& hard = registry->load("hard");
    const config::RenderConfig cfg = test::defaultTestConfig();  // a spot light
    ASSERT_EQ(cfg.lights[0].light.type, scene::LightType::Spot);
    const scene::Scene scene = config::buildScene(cfg.scene);
    const render::SceneGpu sceneGpu(*context, scene);
    const render::Casters casters(sceneGpu);
    const gpu::ShaderCompiler shaders({hard.shaderDir, gpu::engineShaderDir()});
    const plugin::ParamValues params = hard.defaultParams();
    const plugin::TechniqueSetup setup{*context,           shaders,        casters, scene,     params,
                                       cfg.lights[0].light, scene.bounds(), 0,       cfg.width, cfg.height,
                                       "light0.hard."};
    const std::unique_ptr<plugin::Technique> technique = registry->create(hard, setup, "light 0");
    technique->update(cfg.lights[0].light, scene.bounds());  // the same type: fine

    for (const scene::LightType type : {scene::LightType::Directional, scene::LightType::Point}) {
        config::LightConfig other = cfg.lights[0];
        test::setLightType(other, type);
        try {
            technique->update(other.light, scene.bounds());
            ADD_FAILURE() << "a spot light's technique took a " << scene::lightTypeName(type) << " light";
        } catch (const Error& e) {
            const std::string what = e.what();
            EXPECT_NE(what.find("light 0 changed type"), std::string::npos) << what;
            EXPECT_NE(what.find(scene::lightTypeName(type)), std::string::npos) << what;
        }
    }
}

// pcf_kernel is odd-only (ParamSpec::odd): 4 is in range 1..15 but has no centre texel,
// and is refused where it is set, naming where it came from.
TEST_F(HardPluginErrors, EvenPcfKernelIsRejectedNamingTheParameter)
{
    plugin::ParamValues params = registry->load("hard").defaultParams();
    params.set("filter", "pcf", "test");
    try {
        params.set("pcf_kernel", 4, "a.json: /lights/0/shadow/pcf_kernel");
        FAIL() << "pcf_kernel 4 was accepted";
    } catch (const ConfigError& e) {
        const std::string what = e.what();
        EXPECT_NE(what.find("a.json: /lights/0/shadow/pcf_kernel: must be an odd integer in [1, 15]"),
                  std::string::npos)
            << what;
    }
    EXPECT_EQ(params.getInt("pcf_kernel"), 3);  // the refused value left the default
}

TEST_F(HardPluginErrors, EvenPcfKernelInAConfigStopsTheRender)
{
    config::RenderConfig cfg = test::defaultTestConfig();
    HardSettings s;
    s.filter = "pcf";
    s.pcfKernel = 6;
    applySettings(cfg.lights[0], s);
    try {
        render(cfg, config::buildScene(cfg.scene));
        FAIL() << "rendered with pcf_kernel 6";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("pcf_kernel"), std::string::npos) << e.what();
    }
}

TEST_F(HardPluginErrors, CubeAtlasWiderThanTheDeviceAllowsNamesResolution)
{
    // Six faces of R texels need a 3R-wide atlas.
    const uint32_t maxDimension = context->properties().limits.maxImageDimension2D;
    const uint32_t resolution = maxDimension / 3 + 1;
    if (resolution > 16384) GTEST_SKIP() << "this device allows a 3 x 16384 atlas";
    config::RenderConfig cfg = test::defaultTestConfig();
    test::setLightType(cfg.lights[0], scene::LightType::Point);
    plugin::ParamValues params = registry->load("hard").defaultParams();
    params.set("resolution", resolution, "test");
    const std::string what = creationError(params, cfg);
    EXPECT_NE(what.find("resolution"), std::string::npos) << what;
}
