// Every shadow-map technique (hard, PCF, PCSS, VSM, EVSM, ESM, VSSM, backprojection per pixel,
// in packets and with two depth layers, deep shadow maps) under the same extremes,
// end to end through frame::FrameRenderer, with the contract's invariants (every V
// finite and in [0, 1], 1 without geometry: PluginFrame's checkedVisibility) on every
// image:
//   - the horizon: light from below a receiver's tangent plane is blocked by the
//     receiver itself (shaders/common/visibility.glsl), so on a wall that a large rect or
//     disk light straddles every technique and the reference give the part of the light
//     above the wall's plane, and a wall facing away from the light holds exactly 0;
//   - a near/far ratio of 1e6 (camera near 1e-3, a ground reaching 1e3);
//   - degenerate caster triangles (zero area: repeated or collinear vertices);
//   - the error against the ray-traced reference does not grow as the technique's quality
//     knob rises.
// Light size 0, huge lights, blockers touching their receiver, grazing light and scene
// scales 1e-3 and 1e5 are covered per technique in test_hard_plugin.cpp,
// test_pcss_plugin.cpp, test_vsm_plugin.cpp, test_vssm_plugin.cpp and test_deep_plugin.cpp.
#include "ExactVisibility.h"
#include "PluginFrame.h"
#include "TestConfigs.h"
#include "TestContext.h"

#include "penumbra/config/Config.h"
#include "penumbra/metrics/ImageComparison.h"
#include "penumbra/scene/Scene.h"

#include <fmt/format.h>
#include <glm/gtc/matrix_transform.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

using namespace penumbra;

namespace {

struct TechniqueCase {
    const char* name;
    const char* plugin;
    std::vector<std::pair<std::string, nlohmann::json>> params;
    // The quality knob and its values, in rising quality.
    const char* knob;
    std::vector<int> knobValues;
    // The light the technique models: a point light for the hard-shadow family and the
    // VSM family (filtered hard shadows), the rect light for PCSS and VSSM.
    bool areaLightModel = false;
    // The part of the pixels whose V may change by more than 0.05 when the light's depth
    // range grows 50-fold (NearFarRatioOf1e6). The VSM family stores depth over that
    // range (shadowLinearDepth), so its moments' resolution of the same scene falls by
    // as much and light leaks where blockers are close to receivers (measured: VSM and
    // EVSM 1.9%, ESM 9.0% of the pixels, all brighter); the depth-compare techniques are
    // exact up to rounding.
    double nearFarChanged = 0.005;
};

std::ostream& operator<<(std::ostream& os, const TechniqueCase& c) { return os << c.name; }

const TechniqueCase kTechniques[] = {
    {"hard", "hard", {{"resolution", 1024}}, "resolution", {256, 512, 1024, 2048}},
    {"pcf", "hard", {{"resolution", 1024}, {"filter", "pcf"}, {"pcf_kernel", 3}}, "resolution", {256, 512, 1024, 2048}},
    {"pcss", "pcss", {{"resolution", 1024}}, "filter_samples", {4, 8, 16, 32, 64}, true},
    {"vsm", "vsm", {{"resolution", 1024}, {"variant", "vsm"}}, "resolution", {256, 512, 1024, 2048}, false, 0.03},
    {"evsm", "vsm", {{"resolution", 1024}, {"variant", "evsm"}}, "resolution", {256, 512, 1024, 2048}, false, 0.03},
    {"esm", "vsm", {{"resolution", 1024}, {"variant", "esm"}}, "resolution", {256, 512, 1024, 2048}, false, 0.12},
    {"vssm", "vssm", {{"resolution", 1024}}, "resolution", {256, 512, 1024, 2048}, true, 0.03},
    // Rect-light cube atlases of up to 512: a 1024-texel one's multi-scale shadow map takes
    // seconds to build on lavapipe.
    {"backprojection", "backprojection", {{"resolution", 512}, {"packet", "1x1"}}, "resolution", {128, 256, 512}, true},
    // The packet pass with every packet walked as one (eq. 5 and eq. 6 off).
    {"backprojection_packets",
     "backprojection",
     {{"resolution", 512}, {"packet", "3x3"}, {"coherence", "always"}},
     "resolution",
     {128, 256, 512},
     true},
    // A depth-peeled second layer: two maps, two walks, their union on the light.
    {"backprojection_layers",
     "backprojection",
     {{"resolution", 512}, {"packet", "1x1"}, {"layers", 2}},
     "resolution",
     {128, 256, 512},
     true},
    // Deep shadow maps: every fragment in front of the opaque casters in per-texel lists (a
    // point light's hard shadows in an opaque scene), one tap and PCF 3 x 3 over the
    // neighbour links. Up to 1024: a 2048-texel cube atlas holds 25M texels, more nodes
    // than lavapipe binds in one storage buffer (128 MiB, 5.6M nodes).
    {"deep", "deep", {{"resolution", 1024}}, "resolution", {256, 512, 1024}},
    {"deep_pcf", "deep", {{"resolution", 1024}, {"pcf_kernel", 3}}, "resolution", {256, 512, 1024}},
    // Adaptive shadow maps: a quadtree of 128² tiles per cube face refined where the view
    // sees shadow edges under-sampled, the knob its deepest level (2: a uniform 512² map).
    // Without a time budget (refine_ms): how many tiles a frame adds then depends on the
    // scene alone, not on the tile cost calibrated on a loaded machine, so that two renders
    // that must agree settle to the same tree.
    {"adaptive_sm", "adaptive-sm", {{"refine_ms", 1e5}}, "max_level", {2, 4, 6, 8}},
    {"adaptive_sm_pcf", "adaptive-sm", {{"refine_ms", 1e5}, {"pcf_kernel", 3}}, "max_level", {2, 4, 6, 8}},
};

void applyTechnique(config::LightConfig& light, const TechniqueCase& t)
{
    light.shadow = {};
    light.shadow.technique = t.plugin;
    light.shadow.required = true;
    for (const auto& [name, value] : t.params) light.shadow.setParam(name, value, "test");
}

void applyReference(config::LightConfig& light, int samples)
{
    light.shadow = {};
    light.shadow.technique = "reference";
    light.shadow.required = true;
    light.shadow.setParam("samples", samples, "test");
    light.shadow.setParam("cache", false, "test");
}

class Extremes : public test::PluginGpuTest {
protected:
    std::vector<float> renderTechnique(config::RenderConfig cfg, scene::Scene s, const TechniqueCase& t)
    {
        applyTechnique(cfg.lights[0], t);
        render(cfg, std::move(s));
        return frame->checkedVisibility();
    }
    std::vector<float> renderReference(config::RenderConfig cfg, scene::Scene s, int samples)
    {
        applyReference(cfg.lights[0], samples);
        render(cfg, std::move(s));
        return frame->checkedVisibility();
    }
    glm::vec3 normal(size_t pixel) const
    {
        return {frame->normals[4 * pixel], frame->normals[4 * pixel + 1], frame->normals[4 * pixel + 2]};
    }
    double rmse(const std::vector<float>& test, const std::vector<float>& reference) const
    {
        const metrics::PixelMask mask =
            metrics::geometryMask(frame->config.width, frame->config.height, frame->positions);
        return metrics::compareVisibility({frame->config.width, frame->config.height, test},
                                          {frame->config.width, frame->config.height, reference}, &mask)
            .all.rmse;
    }
};

class TechniqueExtremes : public Extremes, public ::testing::WithParamInterface<TechniqueCase> {};

// ---------------------------------------------------------------------------------
// The horizon.

// A 2 x 2 wall in the plane x = 0.5 (y in [0, 2], z in [-1, 1]) on planeScene()'s
// ground, seen from +x: nothing stands between its +x side and any light above at x > 0.5.
scene::Scene wallScene()
{
    scene::Scene s = test::planeScene();
    test::addInstance(s, test::addMesh(s, scene::makePlane("wall")), "wall", test::wallAt(0.5f));
    return s;
}

struct HorizonCase {
    const char* name;
    scene::Light light;
    double expected;  // V on the wall's +x side: the part of the light with x > 0.5
};

std::vector<HorizonCase> horizonCases()
{
    scene::Light rect;
    rect.type = scene::LightType::Rect;
    rect.position = {0.0f, 3.0f, 0.0f};
    rect.direction = {0.0f, -1.0f, 0.0f};
    rect.tangent = {1.0f, 0.0f, 0.0f};
    rect.sizeWorld = {4.0f, 1.0f};  // x in [-2, 2]: 1.5 of its 4 lie beyond x = 0.5
    scene::Light disk = rect;
    disk.type = scene::LightType::Disk;
    disk.radiusWorld = 2.0f;  // the chord x = 0.5 lies 0.25 radii short of the centre
    scene::Light away = rect;
    away.position = {-3.0f, 3.0f, 0.0f};
    away.sizeWorld = {0.5f, 0.5f};  // x in [-3.25, -2.75]: all of it behind the wall's +x side
    return {{"rect_straddling", rect, 1.5 / 4.0},
            {"disk_straddling", disk, test::diskBeyondChord(-0.25)},
            {"rect_behind", away, 0.0}};
}

config::RenderConfig wallConfig(const scene::Light& light)
{
    config::RenderConfig cfg = test::defaultTestConfig();
    cfg.camera.position = {4.0f, 1.2f, 0.0f};
    cfg.camera.target = {0.5f, 1.0f, 0.0f};
    cfg.camera.up = {0.0f, 1.0f, 0.0f};
    cfg.camera.fovYDeg = 45.0f;
    cfg.camera.nearWorld = 0.01f;
    cfg.lights.resize(1);
    cfg.lights[0].light = light;
    cfg.lights[0].light.intensity = 40.0f;
    return cfg;
}

// V on the pixels of the wall's +x side, |V - expected| sorted.
struct WallErrors {
    std::vector<double> sorted;
    double mean = 0.0;
    double quantile(double q) const { return sorted[std::min(sorted.size() - 1, size_t(q * double(sorted.size())))]; }
};

} // namespace

TEST_P(TechniqueExtremes, HorizonClipsTheLightOnAWall)
{
    for (const HorizonCase& c : horizonCases()) {
        SCOPED_TRACE(c.name);
        const std::vector<float> v = renderTechnique(wallConfig(c.light), wallScene(), GetParam());
        WallErrors e;
        size_t nonZero = 0;
        for (size_t i = 0; i < v.size(); ++i) {
            if (!frame->hasGeometry(i) || !(normal(i).x > 0.99f) || std::abs(frame->position(i).x - 0.5f) > 1e-3f)
                continue;
            e.sorted.push_back(std::abs(double(v[i]) - c.expected));
            nonZero += v[i] != 0.0f;
        }
        ASSERT_GT(e.sorted.size(), v.size() / 8) << "wall pixels";
        for (double d : e.sorted) e.mean += d / double(e.sorted.size());
        std::sort(e.sorted.begin(), e.sorted.end());
        if (c.expected == 0.0) {
            // Facing away from the whole light: the horizon alone makes V exactly 0.
            EXPECT_EQ(nonZero, 0u);
            continue;
        }
        // The horizon's share is exact (area measure); what is left is the technique's
        // own filtering where the wall meets the ground and its edges.
        EXPECT_LT(e.mean, 0.01);
        EXPECT_LT(e.quantile(0.9), 0.01);
    }
}

// light_size is -1 (the light's own size) or a size >= 0: a value between, which the
// parameter's range [-1, 1e9] lets through, stops the render naming it (it was taken as
// -1); -1 and 0 render.
TEST_F(Extremes, LightSizeBetweenMinusOneAndZeroIsRefusedNamingIt)
{
    for (const char* technique : {"pcss", "vssm"}) {
        for (const double size : {-0.5, -1e-6, -1.0, 0.0}) {
            SCOPED_TRACE(fmt::format("{} light_size {}", technique, size));
            config::RenderConfig cfg = test::defaultTestConfig();
            cfg.width = 64;
            cfg.height = 36;
            test::setShadow(cfg.lights[0], technique, {{"light_size", size}, {"resolution", 256}});
            const bool meaningful = size == -1.0 || size >= 0.0;
            try {
                render(cfg, config::buildScene(cfg.scene));
                EXPECT_TRUE(meaningful) << "rendered";
            } catch (const Error& e) {
                EXPECT_FALSE(meaningful) << e.what();
                EXPECT_NE(std::string(e.what()).find("light_size"), std::string::npos) << e.what();
                EXPECT_NE(std::string(e.what()).find(technique), std::string::npos) << e.what();
            }
        }
    }
}

// A light of size 0 of any kind gives exactly the point light's shadows (the
// reference's README; configs take a rect size and a disk radius of 0): V of a rect of
// size [0, 0] and of a disk of radius 0 equals V of a point light at the same place, for
// the soft techniques (their light size is then 0: the hard compare) and the reference.
TEST_F(Extremes, ZeroSizeRectAndDiskLightsCastThePointLightsShadows)
{
    for (const char* technique : {"hard", "pcss", "vssm", "reference"}) {
        std::vector<float> v[3];
        for (int kind = 0; kind < 3; ++kind) {
            config::RenderConfig cfg = test::defaultTestConfig();
            cfg.width = 96;
            cfg.height = 54;
            test::setLightType(cfg.lights[0], kind == 0 ? scene::LightType::Point
                                              : kind == 1 ? scene::LightType::Rect
                                                          : scene::LightType::Disk);
            cfg.lights[0].light.position = {-3.0f, 9.0f, 4.0f};  // one place for all three
            cfg.lights[0].light.direction = {0.0f, -1.0f, 0.0f};
            cfg.lights[0].light.sizeWorld = glm::vec2(0.0f);
            cfg.lights[0].light.radiusWorld = 0.0f;
            const nlohmann::json params = std::string(technique) == "reference"
                                              ? nlohmann::json{{"samples", 4}, {"cache", false}}
                                              : nlohmann::json{{"resolution", 512}};
            test::setShadow(cfg.lights[0], technique, params);
            render(cfg, config::buildScene(cfg.scene));
            v[kind] = frame->checkedVisibility();
        }
        SCOPED_TRACE(technique);
        size_t shadowed = 0;
        for (const float x : v[0]) shadowed += x < 0.5f ? 1 : 0;
        EXPECT_GT(shadowed, 100u) << "the point light must cast shadows for the comparison to mean anything";
        EXPECT_EQ(v[1], v[0]) << "rect of size 0";
        EXPECT_EQ(v[2], v[0]) << "disk of radius 0";
    }
}

TEST_F(Extremes, ReferenceClipsTheLightOnAWallSampleBySample)
{
    // 256 correlated multi-jittered samples are stratified along x in 256 strata: the
    // part beyond x = 0.5 is exact to 1/256 per pixel.
    for (const HorizonCase& c : horizonCases()) {
        SCOPED_TRACE(c.name);
        const std::vector<float> v = renderReference(wallConfig(c.light), wallScene(), 256);
        size_t wall = 0;
        double worst = 0.0;
        for (size_t i = 0; i < v.size(); ++i) {
            if (!frame->hasGeometry(i) || !(normal(i).x > 0.99f) || std::abs(frame->position(i).x - 0.5f) > 1e-3f)
                continue;
            ++wall;
            worst = std::max(worst, std::abs(double(v[i]) - c.expected));
        }
        EXPECT_GT(wall, v.size() / 8);
        EXPECT_LE(worst, c.expected == 0.0 ? 0.0 : 0.02);
    }
}

// ---------------------------------------------------------------------------------
// Near/far 1e6: the default scene lit by a point light (a cube map: its texel density
// does not depend on the scene's extent), seen with a camera near plane of 1e-3 over a
// ground reaching 1e3 away (the light's depth range grows 50-fold). Every pixel that
// sees the same surface as in the default view gets the same V, up to the part
// TechniqueCase::nearFarChanged states; what changes may only leak light, never add
// shadow.

TEST_P(TechniqueExtremes, NearFarRatioOf1e6)
{
    config::RenderConfig cfg = test::defaultTestConfig();
    test::setLightType(cfg.lights[0], scene::LightType::Point);
    const std::vector<float> base = renderTechnique(cfg, config::buildScene(cfg.scene), GetParam());
    const std::vector<float> basePositions = frame->positions;

    scene::Scene wide = config::buildScene(cfg.scene);
    scene::Mesh ground = scene::makePlane("far_ground");
    ground.computeBounds();
    wide.meshes.push_back(ground);
    wide.addInstance(uint32_t(wide.meshes.size() - 1),
                     wide.graph.addNode("far_ground", scene::kNoParent,
                                        glm::scale(glm::translate(glm::mat4(1.0f), {0.0f, -1e-3f, 0.0f}),
                                                   {2e3f, 1.0f, 2e3f})));
    cfg.camera.nearWorld = 1e-3f;
    const std::vector<float> v = renderTechnique(cfg, std::move(wide), GetParam());

    // Darker counts beyond 0.1: re-rasterised caster edges (a map's projection differs
    // by rounding, flipping a few texels' coverage) move a blurred VSM penumbra both ways
    // by a few hundredths (measured at one pixel: 0.730-0.752 as cube faces' guard bands
    // shift their texel grid by whole texels), and a shadow added by the depth range
    // would darken by far more.
    constexpr float kDarker = 0.1f;
    size_t same = 0, differ = 0, farGround = 0, darker = 0;
    for (size_t i = 0; i < v.size(); ++i) {
        if (!frame->hasGeometry(i)) continue;
        const glm::vec3 p = frame->position(i);
        if (basePositions[4 * i + 3] == 0.0f) {
            farGround += glm::length(p) > 20.0f;
            continue;
        }
        const glm::vec3 q(basePositions[4 * i], basePositions[4 * i + 1], basePositions[4 * i + 2]);
        if (glm::length(p - q) > 1e-3f) continue;
        ++same;
        differ += std::abs(v[i] - base[i]) > 0.05f;
        darker += base[i] - v[i] > kDarker;
    }
    EXPECT_GT(farGround, 0u) << "the far ground is in view";
    EXPECT_GT(same, v.size() / 2);
    EXPECT_LE(double(differ), GetParam().nearFarChanged * double(same))
        << differ << " of " << same << " pixels differ by more than 0.05, " << darker << " darker by more than "
        << kDarker;
    EXPECT_EQ(darker, 0u) << "darker pixels: shadow where there was none";
}

// ---------------------------------------------------------------------------------
// Degenerate caster triangles: zero-area triangles (three equal vertices, two equal,
// three collinear) in front of the light cover no sample, so the image is unchanged;
// nothing divides by their zero area or normal.

TEST_P(TechniqueExtremes, DegenerateCasterTrianglesChangeNothing)
{
    config::RenderConfig cfg = test::defaultTestConfig();
    const std::vector<float> base = renderTechnique(cfg, config::buildScene(cfg.scene), GetParam());

    scene::Scene s = config::buildScene(cfg.scene);
    scene::Mesh degenerate;
    degenerate.name = "degenerate";
    const glm::vec3 a(0.0f, 1.5f, 0.0f), b(1.0f, 1.5f, 0.0f), c(2.0f, 1.5f, 0.0f);
    for (const glm::vec3& p : {a, a, a, a, a, b, a, b, c}) degenerate.vertices.push_back({p, glm::vec3(0.0f), glm::vec2(0.0f)});
    degenerate.indices = {0, 1, 2, 3, 4, 5, 6, 7, 8};
    degenerate.computeBounds();
    s.meshes.push_back(degenerate);
    s.addInstance(uint32_t(s.meshes.size() - 1), s.graph.addNode("degenerate", scene::kNoParent, glm::mat4(1.0f)));
    const std::vector<float> v = renderTechnique(cfg, std::move(s), GetParam());

    ASSERT_EQ(v.size(), base.size());
    float worst = 0.0f;
    for (size_t i = 0; i < v.size(); ++i) worst = std::max(worst, std::abs(v[i] - base[i]));
    EXPECT_EQ(worst, 0.0f);
}

// ---------------------------------------------------------------------------------
// Quality: the RMSE against the ray-traced reference (of the light the technique
// models) does not grow as the knob rises, beyond 2% + 1e-3 of noise from one value to
// the next, and the best setting beats the worst.

TEST_P(TechniqueExtremes, ErrorDoesNotGrowWithTheQualityKnob)
{
    const TechniqueCase& t = GetParam();
    config::RenderConfig cfg = test::boxOnGroundConfig();
    if (!t.areaLightModel) {
        cfg.lights[0].light.type = scene::LightType::Point;
        cfg.lights[0].light.sizeWorld = glm::vec2(0.0f);
    }
    const std::vector<float> reference = renderReference(cfg, test::boxOnGroundScene(), 64);

    std::vector<double> errors;
    for (int value : t.knobValues) {
        TechniqueCase at = t;
        std::erase_if(at.params, [&](const auto& p) { return p.first == t.knob; });
        at.params.emplace_back(t.knob, value);
        errors.push_back(rmse(renderTechnique(cfg, test::boxOnGroundScene(), at), reference));
    }
    std::string table;
    for (size_t i = 0; i < errors.size(); ++i) table += fmt::format(" {}={:.5f}", t.knobValues[i], errors[i]);
    for (size_t i = 1; i < errors.size(); ++i)
        EXPECT_LE(errors[i], errors[i - 1] * 1.02 + 1e-3) << t.knob << ":" << table;
    EXPECT_LT(errors.back(), errors.front()) << t.knob << ":" << table;
    RecordProperty("rmse_by_" + std::string(t.knob), table);
}

INSTANTIATE_TEST_SUITE_P(Techniques, TechniqueExtremes, ::testing::ValuesIn(kTechniques),
                         [](const ::testing::TestParamInfo<TechniqueCase>& info) { return info.param.name; });
