// The reference plugin (plugins/reference) end to end, through the engine's frame: the
// G-buffer read back, traced on the host, V uploaded. Checked on scenes whose visibility
// is known: hard shadows against the CPU ray caster (tests/support/RayCast.h), soft
// shadows against closed forms, translucent and alpha-masked casters against their
// alpha, at scene scales 1e-3 to 1e5; then determinism, the disk cache, refitting.
#include "ExactVisibility.h"
#include "RayCast.h"
#include "ScratchFolder.h"
#include "TestConfigs.h"
#include "TestContext.h"

#include "penumbra/config/Config.h"
#include "penumbra/core/LeakCheck.h"
#include "penumbra/core/Error.h"
#include "penumbra/frame/FrameRenderer.h"
#include "penumbra/plugin/PluginRegistry.h"
#include "penumbra/plugin/Progress.h"
#include "penumbra/scene/Generators.h"
#include "plugins/reference/ReferenceStats.h"

#include <dlfcn.h>
#include <fmt/format.h>
#include <glm/gtc/matrix_transform.hpp>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <memory>
#include <tuple>

using namespace penumbra;
namespace fs = std::filesystem;

namespace {

PenumbraReferenceStats stats()
{
    const plugin::LoadedPlugin& reference = test::plugins().load("reference");
    void* handle = dlopen(reference.file.c_str(), RTLD_NOW | RTLD_NOLOAD);
    if (!handle) {
        ADD_FAILURE() << "penumbra-reference.so is not loaded";
        return {};
    }
    const auto fn = reinterpret_cast<PenumbraReferenceStatsFn>(dlsym(handle, PENUMBRA_REFERENCE_STATS_SYMBOL));
    const PenumbraReferenceStats s = fn ? fn() : PenumbraReferenceStats{};
    if (!fn) ADD_FAILURE() << "no " << PENUMBRA_REFERENCE_STATS_SYMBOL;
    dlclose(handle);
    return s;
}

scene::Camera lookDown(glm::vec3 position, glm::vec3 target, float fovDeg)
{
    scene::Camera camera;
    camera.position = position;
    camera.target = target;
    camera.up = {0.0f, 0.0f, -1.0f};
    camera.fovYDeg = fovDeg;
    camera.nearWorld = 0.01f * glm::length(position - target);
    return camera;
}

// One light with the reference technique; the cache is off unless `params` turns it on.
config::RenderConfig referenceConfig(uint32_t width, uint32_t height, const scene::Camera& camera,
                                     const scene::Light& light, const nlohmann::json& params = nlohmann::json::object())
{
    config::RenderConfig cfg;
    cfg.width = width;
    cfg.height = height;
    cfg.camera = camera;
    config::LightConfig lc;
    lc.name = "light0";
    lc.light = light;
    lc.shadow.technique = "reference";
    lc.shadow.required = true;
    lc.shadow.setParam("cache", false, "test");
    for (const auto& [name, value] : params.items()) lc.shadow.setParam(name, value, "test");
    cfg.lights = {lc};
    return cfg;
}

// A rendered frame and what the tests read back. Not movable: the renderer keeps
// references to the scene and the config.
struct Frame {
    Frame(gpu::Context& context, const config::RenderConfig& cfg, scene::Scene s)
        : config(cfg), scene(std::move(s)), renderer(context, scene, config, test::plugins())
    {
        render();
    }
    Frame(const Frame&) = delete;
    Frame& operator=(const Frame&) = delete;

    void render()
    {
        renderer.renderFrame();
        visibility = renderer.readVisibility(0);
        positions = renderer.readPositions();
        normals = renderer.readNormals();
    }
    // Moves generatePenumbra's occluder by `offset` (an animated frame: the renderer is
    // told which node moved) and renders.
    void moveOccluder(glm::vec3 offset)
    {
        uint32_t occluder = 0;
        for (const scene::Instance& instance : scene.instances)
            if (scene.meshes[instance.mesh].name == "occluder") occluder = instance.node;
        scene.graph.setLocal(occluder, glm::translate(glm::mat4(1.0f), offset) * scene.graph.local(occluder));
        const std::vector<uint32_t> moved = scene.updateTransforms();
        ASSERT_EQ(moved.size(), 1u);
        renderer.update(config, scene, moved);
        render();
    }
    size_t pixels() const { return visibility.size(); }
    bool hasGeometry(size_t i) const { return positions[4 * i + 3] != 0.0f; }
    glm::dvec3 position(size_t i) const { return {positions[4 * i], positions[4 * i + 1], positions[4 * i + 2]}; }
    glm::dvec3 normal(size_t i) const { return {normals[4 * i], normals[4 * i + 1], normals[4 * i + 2]}; }

    config::RenderConfig config;
    scene::Scene scene;
    frame::FrameRenderer renderer;
    std::vector<float> visibility, positions, normals;
};

// A frame of the analytic scene against penumbraVisibility (the closed form of
// scene/Generators.h) on its ground pixels (the occluder's own are skipped): the RMSE over
// the penumbra pixels (0 < V < 1 analytically), the largest error anywhere, the umbra and
// penumbra pixels, and the umbra and lit pixels whose V is not exactly the closed form's
// 0 or 1 (every sample agrees there).
struct ClosedFormAgreement {
    double rmse = 0.0, worst = 0.0;
    size_t penumbra = 0, umbra = 0, inexact = 0;
};

ClosedFormAgreement agreementWithClosedForm(const Frame& f, const scene::PenumbraParams& params, const scene::Light& light)
{
    const scene::RectAreaLight analyticLight{light.position, light.sizeWorld};
    ClosedFormAgreement a;
    double squared = 0.0;
    for (size_t i = 0; i < f.pixels(); ++i) {
        if (!f.hasGeometry(i) || f.position(i).y > 0.5 * params.occluderHeight) continue;  // the occluder
        const glm::dvec3 p = f.position(i);
        const double expected = scene::penumbraVisibility(params, analyticLight, glm::vec2(p.x, p.z));
        const double error = std::abs(f.visibility[i] - expected);
        a.worst = std::max(a.worst, error);
        if (expected <= 0.0) ++a.umbra;
        if (expected <= 0.0 || expected >= 1.0) {
            a.inexact += f.visibility[i] != float(expected) ? 1 : 0;
            continue;
        }
        squared += error * error;
        ++a.penumbra;
    }
    a.rmse = a.penumbra > 0 ? std::sqrt(squared / double(a.penumbra)) : 0.0;
    return a;
}

// Every V is a number in [0, 1].
::testing::AssertionResult inUnitRange(const std::vector<float>& v)
{
    for (size_t i = 0; i < v.size(); ++i)
        if (!(v[i] >= 0.0f && v[i] <= 1.0f)) return ::testing::AssertionFailure() << "pixel " << i << ": V = " << v[i];
    return ::testing::AssertionSuccess();
}

// The analytic scene: the generator's square occluder (zero thickness: exact) at
// `scale`, seen from above; the scene's own camera and light scaled with it.
scene::PenumbraParams analyticParams(float scale, float occluderSize = 1.0f)
{
    scene::PenumbraParams p;
    p.occluderSize = occluderSize * scale;
    p.occluderThickness = 0.0f;
    p.occluderHeight = 1.0f * scale;
    p.groundSize = 20.0f * scale;
    return p;
}

// A rect light facing down at `position`, its sides along x and z.
scene::Light downwardRect(glm::vec3 position, glm::vec2 size)
{
    scene::Light light;
    light.type = scene::LightType::Rect;
    light.position = position;
    light.direction = {0.0f, -1.0f, 0.0f};
    light.tangent = {1.0f, 0.0f, 0.0f};
    light.sizeWorld = size;
    return light;
}

// The plugin's disk cache in the test's scratch folder (cache/, made by the plugin).
class ReferencePlugin : public test::WithScratchFolder<test::GpuTest> {
protected:
    using Base = test::WithScratchFolder<test::GpuTest>;
    void SetUp() override
    {
        Base::SetUp();
        cacheDir = dir / "cache";
        setenv("PENUMBRA_CACHE_DIR", cacheDir.c_str(), 1);
    }
    void TearDown() override
    {
        frames.clear();
        unsetenv("PENUMBRA_CACHE_DIR");
        Base::TearDown();
    }
    Frame& render(const config::RenderConfig& cfg, scene::Scene scene)
    {
        frames.push_back(std::make_unique<Frame>(*context, cfg, std::move(scene)));
        EXPECT_TRUE(inUnitRange(frames.back()->visibility));
        return *frames.back();
    }
    std::vector<fs::path> cacheFiles() const
    {
        std::vector<fs::path> files;
        if (fs::exists(cacheDir))
            for (const auto& entry : fs::directory_iterator(cacheDir)) files.push_back(entry.path());
        return files;
    }

    fs::path cacheDir;
    std::vector<std::unique_ptr<Frame>> frames;
};

// ---------------------------------------------------------------------------------------
// Geometry at three scales

class ReferenceAtScale : public ReferencePlugin, public ::testing::WithParamInterface<float> {};

// A point light: one ray per pixel, V exactly 0 or 1, and the same answer as the
// independent double-precision ray caster wherever that answer is not decided within
// 1e-4 of the scene's size (an edge through the pixel's point).
TEST_P(ReferenceAtScale, PointLightGivesExactlyTheRayCastersHardShadow)
{
    const float s = GetParam();
    scene::PenumbraParams params = analyticParams(1.0f);
    params.occluderThickness = 0.05f;  // a box: its sides cast too
    scene::Scene scene = scene::generatePenumbra(params);
    scene::scaleScene(scene, s);
    scene::Light light;
    light.type = scene::LightType::Point;
    light.position = glm::vec3(0.3f, 4.0f, 0.2f) * s;
    light.intensity *= s * s;  // the irradiance of scale 1: a light too dim to show is culled
    const Frame& f = render(referenceConfig(64, 48, lookDown(glm::vec3(-1.2f, 5.0f, -0.9f) * s, glm::vec3(0.0f), 40.0f),
                                            light),
                           scene);
    const test::RayCaster caster(f.scene);
    const double radius = f.scene.bounds().radius();
    const glm::dvec3 lightPos(light.position);
    size_t lit = 0, shadowed = 0, ambiguous = 0;
    for (size_t i = 0; i < f.pixels(); ++i) {
        const float v = f.visibility[i];
        ASSERT_TRUE(v == 0.0f || v == 1.0f) << "pixel " << i << ": V = " << v;
        if (!f.hasGeometry(i)) continue;
        const glm::dvec3 origin = f.position(i) + 1e-5 * radius * glm::normalize(f.normal(i));
        const bool blocked = caster.segmentBlocked(origin, lightPos);
        bool decided = true;
        for (const glm::dvec3 shift : {glm::dvec3(1, 0, 0), glm::dvec3(0, 0, 1)})
            for (double sign : {-1.0, 1.0})
                decided = decided && caster.segmentBlocked(origin + sign * 1e-4 * radius * shift, lightPos) == blocked;
        if (!decided) {
            ++ambiguous;
            continue;
        }
        EXPECT_EQ(v, blocked ? 0.0f : 1.0f) << "pixel " << i << " at " << f.position(i).x << ", " << f.position(i).y
                                            << ", " << f.position(i).z;
        (blocked ? shadowed : lit)++;
    }
    EXPECT_GT(shadowed, 100u);
    EXPECT_GT(lit, 1000u);
    EXPECT_LT(ambiguous, f.pixels() / 20);
}

// A rectangular light over the square occluder: V against penumbraVisibility (the
// closed form of scene/Generators.h: the overlap of the back-projected square with the
// light, linear across the penumbra of each edge). RMSE over the penumbra pixels
// (0 < V < 1 analytically) at 256 samples: <= 0.01.
TEST_P(ReferenceAtScale, RectLightMatchesTheAnalyticPenumbra)
{
    const float s = GetParam();
    const scene::PenumbraParams params = analyticParams(s);
    scene::Light light = downwardRect(glm::vec3(0.0f, 4.0f, 0.0f) * s, glm::vec2(0.8f, 0.5f) * s);
    light.intensity *= s * s;
    // Oblique enough that some of the umbra shows beside the occluder.
    const scene::Camera camera = lookDown(glm::vec3(1.2f, 5.0f, 0.9f) * s, glm::vec3(0.3f, 0.0f, 0.2f) * s, 36.0f);
    const Frame& f = render(referenceConfig(96, 72, camera, light, {{"samples", 256}}), scene::generatePenumbra(params));
    const ClosedFormAgreement a = agreementWithClosedForm(f, params, light);
    ASSERT_GT(a.penumbra, 200u);
    EXPECT_GT(a.umbra, 50u);
    EXPECT_EQ(a.inexact, 0u) << "umbra and lit pixels hold exactly 0 and 1";
    RecordProperty("penumbra_rmse", fmt::format("{:.5f}", a.rmse));
    EXPECT_LE(a.rmse, 0.01) << a.penumbra << " penumbra pixels";
}

INSTANTIATE_TEST_SUITE_P(Scales, ReferenceAtScale, ::testing::Values(1e-3f, 1.0f, 1e5f),
                         [](const ::testing::TestParamInfo<float>& info) {
                             return info.param < 1.0f ? std::string("Milli") : info.param > 1.0f ? "HundredThousand" : "One";
                         });

// Contact (issue 19): the square occluder 1e-3 of its size above the ground, a 2 x 2
// light 3 above it, and the camera straight above the outer part of one edge's penumbra
// (5e-4 of the occluder's size wide). Shadow rays start off the receiver by a few times
// the G-buffer position's error bound (kRayOffsetBounds), so the penumbra lies where the
// closed form puts it at any scale; the offset of before (1e-5 of the scene's radius)
// lifted the origins by 15 % of the gap and shrank the penumbra by as much (RMSE 0.06).
// RMSE over the penumbra pixels <= 0.01 and no pixel off by more than 1/16 + 0.02 (256
// stratified samples, 16 columns across the light).
class ReferenceContact : public ReferencePlugin, public ::testing::WithParamInterface<float> {};

TEST_P(ReferenceContact, ContactShadowMatchesTheAnalyticPenumbra)
{
    const float s = GetParam();
    scene::PenumbraParams params = analyticParams(s);
    params.occluderHeight = 1e-3f * s;
    scene::Light light = downwardRect(glm::vec3(0.0f, 3.0f, 0.0f) * s, glm::vec2(2.0f, 2.0f) * s);
    light.intensity *= s * s;
    // The edge x = 0.5: its penumbra on the ground spans x in [0.5 - 1.7e-4, 0.5 + 5e-4];
    // the part under the occluder is hidden from above.
    const glm::vec3 target = glm::vec3(0.5f + 2e-4f, 0.0f, 0.0f) * s;
    const scene::Camera camera = lookDown(target + glm::vec3(0.0f, 1e-2f, 0.0f) * s, target, 8.0f);
    const Frame& f = render(referenceConfig(96, 72, camera, light, {{"samples", 256}}), scene::generatePenumbra(params));
    const ClosedFormAgreement a = agreementWithClosedForm(f, params, light);
    ASSERT_GT(a.penumbra, 500u) << "the view must resolve the penumbra";
    EXPECT_EQ(a.inexact, 0u) << "lit pixels hold exactly 1";
    RecordProperty("penumbra_rmse", fmt::format("{:.5f}", a.rmse));
    EXPECT_LE(a.rmse, 0.01) << a.penumbra << " penumbra pixels";
    EXPECT_LE(a.worst, 1.0 / 16.0 + 0.02);
}

INSTANTIATE_TEST_SUITE_P(Scales, ReferenceContact, ::testing::Values(1e-4f, 1.0f, 1e6f),
                         [](const ::testing::TestParamInfo<float>& info) {
                             return info.param < 1.0f ? std::string("TenThousandth")
                                    : info.param > 1.0f ? "Million"
                                                        : "One";
                         });

// A disk light beside the straight edge of a large occluder: the hidden part of the
// light is a circular segment, V = (acos d - d sqrt(1 - d²)) / pi with d the back-projected
// edge's offset from the light's centre in radii.
TEST_F(ReferencePlugin, DiskLightMatchesTheCircularSegmentAtAStraightEdge)
{
    const scene::PenumbraParams params = analyticParams(1.0f, 6.0f);
    scene::Light light;
    light.type = scene::LightType::Disk;
    light.position = {0.0f, 4.0f, 0.0f};
    light.direction = {0.0f, -1.0f, 0.0f};
    light.radiusWorld = 0.4f;
    const Frame& f = render(referenceConfig(96, 48, lookDown({4.0f, 5.0f, 0.001f}, {4.0f, 0.0f, 0.0f}, 20.0f), light,
                                            {{"samples", 256}}),
                           scene::generatePenumbra(params));
    const double h = params.occluderHeight, H = light.position.y, R = light.radiusWorld, half = 0.5 * params.occluderSize;
    double squared = 0.0;
    size_t penumbra = 0;
    for (size_t i = 0; i < f.pixels(); ++i) {
        const glm::dvec3 p = f.position(i);
        if (!f.hasGeometry(i) || p.y > 0.5 * h || std::abs(p.z) > 1.0) continue;
        // Light points with x below the back-projected edge are hidden.
        const double d = std::clamp((p.x + (half - p.x) * H / h) / R, -1.0, 1.0);
        const double expected = test::diskBeyondChord(-d);
        if (expected <= 0.0 || expected >= 1.0) continue;
        squared += (f.visibility[i] - expected) * (f.visibility[i] - expected);
        ++penumbra;
    }
    ASSERT_GT(penumbra, 100u);
    const double rmse = std::sqrt(squared / double(penumbra));
    RecordProperty("penumbra_rmse", fmt::format("{:.5f}", rmse));
    EXPECT_LE(rmse, 0.01);
}

// Spheres and the sun have extent too: umbra, penumbra and light all show, and a light
// of size 0 of every kind is exactly the point light (one ray).
TEST_F(ReferencePlugin, LightSizeZeroEqualsThePointLightAndSizedLightsSoften)
{
    const scene::Camera camera = lookDown({1.0f, 5.0f, 0.7f}, {0.0f, 0.0f, 0.0f}, 40.0f);
    const scene::PenumbraParams params = analyticParams(1.0f);
    scene::Light point;
    point.type = scene::LightType::Point;
    point.position = {0.3f, 4.0f, -0.2f};
    const std::vector<float> hard = render(referenceConfig(48, 36, camera, point), scene::generatePenumbra(params)).visibility;

    scene::Light rect = point, disk = point, sphere = point;
    rect.type = scene::LightType::Rect;
    rect.sizeWorld = {0.0f, 0.0f};
    disk.type = scene::LightType::Disk;
    disk.radiusWorld = 0.0f;
    for (const scene::Light& light : {rect, disk, sphere}) {
        SCOPED_TRACE(scene::lightTypeName(light.type));
        EXPECT_EQ(render(referenceConfig(48, 36, camera, light, {{"samples", 64}}), scene::generatePenumbra(params)).visibility,
                  hard);
    }

    scene::Light sun;
    sun.type = scene::LightType::Directional;
    sun.direction = glm::normalize(glm::vec3(0.2f, -1.0f, 0.1f));
    sun.angularDiameterDeg = 12.0f;
    sphere.radiusWorld = 0.3f;
    for (const scene::Light& light : {sphere, sun}) {
        SCOPED_TRACE(scene::lightTypeName(light.type));
        const std::vector<float>& v =
            render(referenceConfig(48, 36, camera, light, {{"samples", 64}}), scene::generatePenumbra(params)).visibility;
        const auto count = [&](auto predicate) { return std::count_if(v.begin(), v.end(), predicate); };
        EXPECT_GT(count([](float x) { return x == 0.0f; }), 20);
        EXPECT_GT(count([](float x) { return x > 0.0f && x < 1.0f; }), 20);
        EXPECT_GT(count([](float x) { return x == 1.0f; }), 200);
    }

    // The config gives a point light its radius.
    const config::RenderConfig parsed = config::parseConfig(
        nlohmann::json::parse(R"({"scene": {"generator": "penumbra"}, "camera": {"position": [0, 2, 5], "target": [0, 0, 0]},
                                  "lights": [{"type": "point", "position": [0, 4, 0], "radius": 0.25}]})"),
        "test.json");
    EXPECT_EQ(parsed.lights[0].light.radiusWorld, 0.25f);
}

// ---------------------------------------------------------------------------------------
// Translucent and alpha-masked casters

// test::panesScene of alpha 0.3 ([-1, 1]² at the given heights) under a point light off to the
// side: a ground point behind k panes gets 0.7^k.
TEST_F(ReferencePlugin, TranslucentPanesAttenuateByOneMinusAlphaEach)
{
    scene::Light light;
    light.type = scene::LightType::Point;
    light.position = {3.0f, 4.0f, 0.0f};
    const scene::Camera camera = lookDown({-2.5f, 6.0f, 0.001f}, {-2.5f, 0.0f, 0.0f}, 40.0f);
    for (const std::vector<float>& heights : {std::vector<float>{1.0f}, std::vector<float>{1.0f, 1.5f}}) {
        SCOPED_TRACE(fmt::format("{} pane(s)", heights.size()));
        const Frame& f = render(referenceConfig(64, 48, camera, light),
                                test::panesScene(heights, 0.3f));
        size_t counted[3] = {0, 0, 0};
        for (size_t i = 0; i < f.pixels(); ++i) {
            const glm::dvec3 p = f.position(i);
            if (!f.hasGeometry(i) || p.y > 0.1) continue;
            int crossed = 0;
            bool nearEdge = false;
            for (float h : heights) {
                const glm::dvec3 at = p + (glm::dvec3(light.position) - p) * (double(h) / light.position.y);
                const double inside = 1.0 - std::max(std::abs(at.x), std::abs(at.z));  // > 0 inside the pane
                nearEdge = nearEdge || std::abs(inside) < 0.03;
                crossed += inside > 0.0 ? 1 : 0;
            }
            if (nearEdge) continue;
            EXPECT_NEAR(f.visibility[i], std::pow(0.7, crossed), 1e-5) << "pixel " << i << ", " << crossed << " pane(s)";
            ++counted[crossed];
        }
        for (size_t k = 0; k <= heights.size(); ++k) EXPECT_GT(counted[k], 50u) << k << " pane(s) crossed";
    }
}

// On the half-masked quad's ground (test::halfMaskedQuadConfig): V = 1 exactly where
// light comes through the transparent half, 0 exactly behind the opaque half.
void expectHalfMaskedQuadShadow(const Frame& f)
{
    size_t throughHoles = 0, behindOpaque = 0;
    for (size_t i = 0; i < f.pixels(); ++i) {
        const glm::dvec3 p = f.position(i);
        if (!f.hasGeometry(i) || p.y > 0.1 || std::abs(p.z) > 1.8) continue;
        if (p.x > -0.85 && p.x < 0.85) {
            EXPECT_EQ(f.visibility[i], 1.0f) << "pixel " << i << " at x = " << p.x;
            ++throughHoles;
        } else if (p.x > 1.15 && p.x < 2.85) {
            EXPECT_EQ(f.visibility[i], 0.0f) << "pixel " << i << " at x = " << p.x;
            ++behindOpaque;
        }
    }
    EXPECT_GT(throughHoles, 30u);
    EXPECT_GT(behindOpaque, 30u);
}

// The half-masked quad (tests/support): light passes where the texture's alpha is below
// the cutoff, as the raster path cuts its holes; the opaque half casts a full shadow.
TEST_F(ReferencePlugin, MaskedTextureHolesLetLightThrough)
{
    const config::RenderConfig base = test::halfMaskedQuadConfig();
    scene::Camera camera = base.camera;
    expectHalfMaskedQuadShadow(
        render(referenceConfig(64, 48, camera, base.lights[0].light), test::halfMaskedQuadScene()));
}

// ---------------------------------------------------------------------------------------
// Determinism, cache, animation

config::RenderConfig smallRectConfig(const nlohmann::json& params)
{
    scene::Light light;
    light.type = scene::LightType::Rect;
    light.position = {0.2f, 3.0f, 0.0f};
    light.direction = {0.0f, -1.0f, 0.0f};
    light.sizeWorld = {0.6f, 0.6f};
    return referenceConfig(48, 36, lookDown({0.5f, 4.0f, 1.5f}, {0.0f, 0.0f, 0.0f}, 45.0f), light, params);
}

TEST_F(ReferencePlugin, SameSeedGivesABitIdenticalImageOnAnyThreadCount)
{
    const scene::Scene scene = scene::generatePenumbra({});
    const std::vector<float> one =
        render(smallRectConfig({{"samples", 49}, {"seed", 7}, {"threads", 1}}), scene).visibility;
    const std::vector<float> three =
        render(smallRectConfig({{"samples", 49}, {"seed", 7}, {"threads", 3}}), scene).visibility;
    EXPECT_EQ(std::memcmp(one.data(), three.data(), one.size() * sizeof(float)), 0);
    const std::vector<float> otherSeed =
        render(smallRectConfig({{"samples", 49}, {"seed", 8}, {"threads", 3}}), scene).visibility;
    EXPECT_NE(one, otherSeed) << "the seed changes the jitter";
}

TEST_F(ReferencePlugin, SecondRunComesFromTheCacheAndDamagedFilesAreIgnored)
{
    const scene::Scene scene = scene::generatePenumbra({});
    const config::RenderConfig cfg = smallRectConfig({{"samples", 16}, {"cache", true}});
    const PenumbraReferenceStats before = stats();
    Frame& first = render(cfg, scene);
    const std::vector<float> traced = first.visibility;
    PenumbraReferenceStats now = stats();
    EXPECT_EQ(now.framesTraced - before.framesTraced, 1u);
    EXPECT_EQ(now.cacheWrites - before.cacheWrites, 1u);
    // Every pixel sees geometry; samples below a surface's horizon (a blocker's far side
    // seen at a silhouette) need no ray.
    const uint64_t rays = now.raysTraced - before.raysTraced;
    EXPECT_LE(rays, 16u * 48u * 36u);
    EXPECT_GE(rays, 16u * 48u * 35u);
    const std::vector<fs::path> files = cacheFiles();
    ASSERT_EQ(files.size(), 1u);

    // The same frame again: the renderer's last image; a new renderer: the file.
    first.render();
    EXPECT_EQ(first.visibility, traced);
    EXPECT_EQ(render(cfg, scene).visibility, traced);
    PenumbraReferenceStats after = stats();
    EXPECT_EQ(after.framesTraced, now.framesTraced) << "a cached frame traced rays";
    EXPECT_EQ(after.cacheHits - now.cacheHits, 2u);

    // Truncated, one flipped byte, a FIFO in its place (it blocked the read): each is
    // rejected, traced again, rewritten whole.
    const auto size = fs::file_size(files[0]);
    const std::vector<std::function<void()>> damages = {
        [&] { fs::resize_file(files[0], size / 2); },
        [&] {
            std::fstream file(files[0], std::ios::in | std::ios::out | std::ios::binary);
            file.seekp(std::streamoff(size / 2));
            file.put('\x7f');
        },
        [&] {
            fs::remove(files[0]);
            ASSERT_EQ(::mkfifo(files[0].c_str(), 0600), 0);
        },
    };
    for (size_t d = 0; d < damages.size(); ++d) {
        SCOPED_TRACE(d == 0 ? "truncated" : d == 1 ? "flipped byte" : "FIFO");
        damages[d]();
        now = stats();
        EXPECT_EQ(render(cfg, scene).visibility, traced);
        after = stats();
        EXPECT_EQ(after.cacheRejected - now.cacheRejected, 1u);
        EXPECT_EQ(after.framesTraced - now.framesTraced, 1u);
        EXPECT_EQ(fs::file_size(files[0]), size);
        EXPECT_EQ(cacheFiles().size(), 1u) << "no temporary file stays behind";
    }
    now = stats();
    EXPECT_EQ(render(cfg, scene).visibility, traced);
    EXPECT_EQ(stats().cacheHits - now.cacheHits, 1u);

    // Another parameter is another key; cache off writes nothing and always traces.
    render(smallRectConfig({{"samples", 16}, {"seed", 2}, {"cache", true}}), scene);
    EXPECT_EQ(cacheFiles().size(), 2u);
    now = stats();
    Frame& uncached = render(smallRectConfig({{"samples", 16}}), scene);
    uncached.render();
    EXPECT_EQ(stats().framesTraced - now.framesTraced, 2u);
    EXPECT_EQ(cacheFiles().size(), 2u);
}

// Moving the occluder's node (an animated frame) refits the Embree scene: the next frame
// is what a renderer built on the moved scene gives.
TEST_F(ReferencePlugin, MovedInstancesAreTracedWhereTheyAreNow)
{
    const config::RenderConfig cfg = smallRectConfig({{"samples", 16}});
    Frame& frame = render(cfg, scene::generatePenumbra({}));
    const std::vector<float> before = frame.visibility;
    ASSERT_NO_FATAL_FAILURE(frame.moveOccluder({0.4f, 0.0f, 0.0f}));
    EXPECT_NE(frame.visibility, before);
    EXPECT_EQ(render(cfg, frame.scene).visibility, frame.visibility);
}

// The tracing reports its rows to a waiting viewer (plugin/Progress.h): one pass per
// traced light, ending at 1; nothing when nobody waits.
TEST_F(ReferencePlugin, TracingReportsItsProgressToTheThreadsSink)
{
    config::RenderConfig cfg = smallRectConfig({{"samples", 4}});
    config::LightConfig second = cfg.lights.at(0);
    second.name = "light1";
    cfg.lights.push_back(second);
    plugin::ProgressSink sink;
    {
        const plugin::ProgressScope scope(sink);
        render(cfg, scene::generatePenumbra({}));
    }
    EXPECT_EQ(sink.passes.load(), 2u);
    EXPECT_DOUBLE_EQ(sink.fraction.load(), 1.0);
}

TEST_F(ReferencePlugin, ParametersAreReflectedWithRanges)
{
    const plugin::LoadedPlugin& reference = test::plugins().load("reference");
    plugin::ParamValues params = reference.defaultParams();
    EXPECT_EQ(params.getInt("samples"), 256);
    EXPECT_EQ(params.getEnum("mode"), "ray_traced");
    EXPECT_TRUE(params.getBool("cache"));
    EXPECT_THROW(params.set("samples", 0, "test"), ConfigError);
    EXPECT_THROW(params.set("threads", -1, "test"), ConfigError);
    EXPECT_THROW(params.set("mode", "shadow_maps", "test"), ConfigError);
    EXPECT_EQ(params.getInt("map_resolution"), 512);
    params.set("mode", "brute_force", "test");
    EXPECT_EQ(params.getEnum("mode"), "brute_force");
}

// ---------------------------------------------------------------------------------------
// mode brute_force: the rasterised reference (RasterReference.h)

// The same frame with the hard plugin: one nearest compare with receiver plane bias,
// the map at `resolution` texels per face.
config::RenderConfig hardConfig(config::RenderConfig cfg, uint32_t resolution)
{
    config::ShadowSettings& shadow = cfg.lights.at(0).shadow;
    shadow = {};
    shadow.technique = "hard";
    shadow.required = true;
    shadow.setParam("bias_mode", "receiver_plane", "test");
    shadow.setParam("filter", "none", "test");
    shadow.setParam("resolution", resolution, "test");
    return cfg;
}

// Whether pixel i of a width-wide image lies at a shadow edge of v: a pixel of its 3 x 3
// neighbourhood has another value.
bool atShadowEdge(const std::vector<float>& v, size_t i, size_t width)
{
    const auto x = ptrdiff_t(i % width), y = ptrdiff_t(i / width), height = ptrdiff_t(v.size() / width);
    for (ptrdiff_t dy = -1; dy <= 1; ++dy)
        for (ptrdiff_t dx = -1; dx <= 1; ++dx) {
            const ptrdiff_t nx = x + dx, ny = y + dy;
            if (nx < 0 || ny < 0 || nx >= ptrdiff_t(width) || ny >= height) continue;
            if (v[size_t(ny) * width + size_t(nx)] != v[i]) return true;
        }
    return false;
}

// LeakSanitizer's check walks every live thread's dynamic TLS and could crash on one of
// TBB's workers, which Embree's BVH builds start (core/LeakCheck.h): in AddressSanitizer
// builds the check first stops them. In a child process: a hard-shadowed frame first (the
// driver's threads start), then a traced one (TBB's pool starts); after the check the
// threads are those before the trace.
TEST_F(ReferencePlugin, TheLeakCheckStopsTheWorkerThreadsEmbreeStarted)
{
#if !defined(__SANITIZE_ADDRESS__)
    GTEST_SKIP() << "the leak check, and with it the stop, runs in AddressSanitizer builds";
#else
    const auto threadCount = [] {
        return std::distance(fs::directory_iterator("/proc/self/task"), fs::directory_iterator{});
    };
    GTEST_FLAG_SET(death_test_style, "threadsafe");
    EXPECT_EXIT(
        {
            const config::RenderConfig cfg = smallRectConfig({{"samples", 4}});
            render(hardConfig(cfg, 256), scene::generatePenumbra({}));
            const auto before = threadCount();
            render(cfg, scene::generatePenumbra({}));
            const auto tracing = threadCount();
            frames.clear();
            penumbra::checkLeaksBeforeExit();
            const auto after = threadCount();
            std::fprintf(stderr, "threads: %td before the trace, %td after it, %td after the check\n", before,
                         tracing, after);
            std::exit(tracing > before && after == before ? 0 : 1);
        },
        testing::ExitedWithCode(0), "");
#endif
}

// A point light has one sample, so brute_force is one hard shadow map: exactly the hard
// plugin's nearest compare with receiver plane bias at the same resolution (same map,
// same bias, same compare), and the ray-traced image except at shadow edges, where a
// texel of the map (about a third of a pixel here) moves the edge: at most 2 % of the
// pixels, every one beside an edge of the traced image. A spot light likewise (its own
// perspective map; outside its cone V = 1, as the rays see it).
TEST_F(ReferencePlugin, BruteForcePointLightIsTheHardShadowAndTheTracedOneButAtEdges)
{
    scene::PenumbraParams params = analyticParams(1.0f);
    params.occluderThickness = 0.05f;
    scene::Light point;
    point.type = scene::LightType::Point;
    point.position = {0.3f, 4.0f, 0.2f};
    scene::Light spot = point;
    spot.type = scene::LightType::Spot;
    spot.direction = {0.0f, -1.0f, 0.0f};
    spot.outerConeDeg = 15.0f;  // the view sees beyond the cone
    for (const scene::Light& light : {point, spot}) {
        const std::string name = scene::lightTypeName(light.type);
        const config::RenderConfig traced =
            referenceConfig(64, 48, lookDown({-1.2f, 5.0f, -0.9f}, {0.0f, 0.0f, 0.0f}, 40.0f), light);
        config::RenderConfig raster = traced;
        raster.lights[0].shadow.setParam("mode", "brute_force", "test");
        raster.lights[0].shadow.setParam("map_resolution", 512, "test");
        const std::vector<float> expected = render(traced, scene::generatePenumbra(params)).visibility;
        const std::vector<float> brute = render(raster, scene::generatePenumbra(params)).visibility;
        const std::vector<float> hard = render(hardConfig(traced, 512), scene::generatePenumbra(params)).visibility;
        EXPECT_EQ(brute, hard) << name;
        size_t differing = 0, shadowed = 0;
        for (size_t i = 0; i < brute.size(); ++i) {
            ASSERT_TRUE(brute[i] == 0.0f || brute[i] == 1.0f) << name << " pixel " << i << ": V = " << brute[i];
            if (brute[i] == 0.0f) ++shadowed;
            if (brute[i] == expected[i]) continue;
            ++differing;
            EXPECT_TRUE(atShadowEdge(expected, i, 64)) << name << " pixel " << i << " differs away from an edge";
        }
        EXPECT_GT(shadowed, 100u) << name;
        EXPECT_LE(differing, brute.size() / 50) << name;
        RecordProperty("differing_pixels_" + name, int(differing));
    }
}

// RMSEs over the penumbra pixels of the analytic scene (0 < V < 1 in closed form).
struct PenumbraErrors {
    double bruteVsTraced = 0.0, bruteVsAnalytic = 0.0, tracedVsAnalytic = 0.0;
    size_t pixels = 0;
};

class ReferenceBruteForce : public ReferencePlugin {
protected:
    // The analytic rect-light scene of RectLightMatchesTheAnalyticPenumbra at `scale`:
    // brute_force with `samples` maps against ray_traced with as many rays per pixel,
    // and both against penumbraVisibility().
    PenumbraErrors rectPenumbraErrors(uint32_t samples, uint32_t mapResolution, float scale = 1.0f)
    {
        const scene::PenumbraParams params = analyticParams(scale);
        scene::Light light;
        light.type = scene::LightType::Rect;
        light.position = glm::vec3(0.0f, 4.0f, 0.0f) * scale;
        light.direction = {0.0f, -1.0f, 0.0f};
        light.tangent = {1.0f, 0.0f, 0.0f};
        light.sizeWorld = glm::vec2(0.8f, 0.5f) * scale;
        light.intensity *= scale * scale;  // the irradiance of scale 1: a light too dim to show is culled
        const scene::Camera camera =
            lookDown(glm::vec3(1.2f, 5.0f, 0.9f) * scale, glm::vec3(0.3f, 0.0f, 0.2f) * scale, 36.0f);
        const config::RenderConfig traced = referenceConfig(96, 72, camera, light, {{"samples", samples}});
        config::RenderConfig raster = traced;
        raster.lights[0].shadow.setParam("mode", "brute_force", "test");
        raster.lights[0].shadow.setParam("map_resolution", mapResolution, "test");
        const Frame& t = render(traced, scene::generatePenumbra(params));
        const Frame& b = render(raster, scene::generatePenumbra(params));
        const scene::RectAreaLight analyticLight{light.position, light.sizeWorld};
        double bt = 0.0, ba = 0.0, ta = 0.0;
        PenumbraErrors e;
        for (size_t i = 0; i < b.pixels(); ++i) {
            if (!b.hasGeometry(i) || b.position(i).y > 0.5 * params.occluderHeight) continue;
            const glm::dvec3 p = b.position(i);
            const double expected = scene::penumbraVisibility(params, analyticLight, glm::vec2(p.x, p.z));
            if (expected <= 0.0 || expected >= 1.0) continue;
            const double vb = b.visibility[i], vt = t.visibility[i];
            bt += (vb - vt) * (vb - vt);
            ba += (vb - expected) * (vb - expected);
            ta += (vt - expected) * (vt - expected);
            ++e.pixels;
        }
        if (e.pixels == 0) return e;
        e.bruteVsTraced = std::sqrt(bt / double(e.pixels));
        e.bruteVsAnalytic = std::sqrt(ba / double(e.pixels));
        e.tracedVsAnalytic = std::sqrt(ta / double(e.pixels));
        const std::string at = fmt::format("_{}_maps_scale_{:g}", samples, scale);
        RecordProperty("rmse_brute_force_vs_ray_traced" + at, fmt::format("{:.5f}", e.bruteVsTraced));
        RecordProperty("rmse_brute_force_vs_analytic" + at, fmt::format("{:.5f}", e.bruteVsAnalytic));
        RecordProperty("rmse_ray_traced_vs_analytic" + at, fmt::format("{:.5f}", e.tracedVsAnalytic));
        return e;
    }
};

// 64 maps against 64 rays per pixel and the closed form, over the penumbra pixels, at
// scene scales 1e-3, 1 and 1e5.
// Measured (lavapipe): 0.0169 against the rays, 0.0159 against the closed form (the rays:
// 0.0070). One pattern shared by every pixel leaves steps of 1/64 across the penumbra
// where the rays' per-pixel patterns leave noise: bounds 0.03.
TEST_F(ReferenceBruteForce, RectLightMatchesTheTracedAndTheAnalyticPenumbra)
{
    for (const float scale : {1e-3f, 1.0f, 1e5f}) {
        const PenumbraErrors e = rectPenumbraErrors(64, 512, scale);
        ASSERT_GT(e.pixels, 200u) << "scale " << scale;
        EXPECT_LE(e.bruteVsTraced, 0.03) << "scale " << scale;
        EXPECT_LE(e.bruteVsAnalytic, 0.03) << "scale " << scale;
    }
}

// The rasterised 256-map reference against 256 rays per pixel, the figure the issue
// asks for. Measured (lavapipe): 0.0047 against the rays, 0.0041 against the closed form
// (the rays: 0.0022): bounds 0.01, the traced reference's own bound against the closed
// form.
TEST_F(ReferenceBruteForce, With256MapsIsWithinTheBoundOfTheTracedReference)
{
    const PenumbraErrors e = rectPenumbraErrors(256, 512);
    ASSERT_GT(e.pixels, 200u);
    EXPECT_LE(e.bruteVsTraced, 0.01);
    EXPECT_LE(e.bruteVsAnalytic, 0.01);
}

// Spheres, the sun and disks: brute_force with 256 samples against ray_traced with 256,
// RMSE over every pixel of the analytic scene. A sphere's samples cover its surface,
// weighed by solid angle at each receiver; the sun's are the traced cone's directions; a
// disk's the traced points. Measured (lavapipe): sphere 0.0036, sun 0.0033, disk 0.0015:
// bound 0.015.
TEST_F(ReferenceBruteForce, SphereSunAndDiskMatchTheTracedOnes)
{
    const scene::Camera camera = lookDown({1.0f, 5.0f, 0.7f}, {0.0f, 0.0f, 0.0f}, 40.0f);
    scene::Light sphere;
    sphere.type = scene::LightType::Point;
    sphere.position = {0.2f, 4.0f, 0.1f};
    sphere.radiusWorld = 0.4f;
    scene::Light sun;
    sun.type = scene::LightType::Directional;
    sun.direction = glm::normalize(glm::vec3(0.2f, -1.0f, 0.1f));
    sun.angularDiameterDeg = 12.0f;
    scene::Light disk;
    disk.type = scene::LightType::Disk;
    disk.position = {0.2f, 4.0f, 0.1f};
    disk.direction = {0.0f, -1.0f, 0.0f};
    disk.radiusWorld = 0.4f;
    for (const scene::Light& light : {sphere, sun, disk}) {
        const config::RenderConfig traced = referenceConfig(64, 48, camera, light, {{"samples", 256}});
        config::RenderConfig raster = traced;
        raster.lights[0].shadow.setParam("mode", "brute_force", "test");
        const std::vector<float> t = render(traced, scene::generatePenumbra(analyticParams(1.0f))).visibility;
        const std::vector<float> b = render(raster, scene::generatePenumbra(analyticParams(1.0f))).visibility;
        double squared = 0.0;
        size_t soft = 0;
        for (size_t i = 0; i < t.size(); ++i) {
            squared += (b[i] - t[i]) * (b[i] - t[i]);
            if (t[i] > 0.0f && t[i] < 1.0f) ++soft;
        }
        const double rmse = std::sqrt(squared / double(t.size()));
        const std::string name = scene::lightTypeName(light.type);
        RecordProperty("rmse_" + name, fmt::format("{:.5f}", rmse));
        EXPECT_GT(soft, 60u) << name;
        EXPECT_LE(rmse, 0.015) << name;
    }
}

// The horizon: a light sample below the receiver's tangent plane counts as blocked,
// even where no caster lies between: a ground lit from below only is its own nearest
// caster in every map, which a depth compare alone calls lit; V = 0. A vertical rect
// light centred in the ground's plane has 32 of its 64 samples above the ground: V is
// 32 / 64 at most, and less by the samples that graze the ground (within about 2
// degrees, where receiver plane bias gives up: README.md), measured 2 to 8 of them.
TEST_F(ReferenceBruteForce, SamplesBelowTheHorizonAreBlocked)
{
    const scene::Camera camera = lookDown({0.0f, 6.0f, 0.001f}, {0.0f, 0.0f, 0.0f}, 30.0f);
    scene::Light straddling;
    straddling.type = scene::LightType::Rect;
    straddling.position = {4.0f, 0.0f, 0.0f};
    straddling.direction = {-1.0f, 0.0f, 0.0f};
    straddling.tangent = {0.0f, 0.0f, 1.0f};  // the other side, along y, is cut in half by the ground
    straddling.sizeWorld = {1.0f, 1.0f};
    scene::Light below = straddling;
    below.position = {4.0f, -1.0f, 0.0f};
    for (const auto& [light, lowest, highest] : {std::tuple{straddling, 0.5f - 12.0f / 64.0f, 0.5f},
                                                 std::tuple{below, 0.0f, 0.0f}}) {
        const Frame& f = render(referenceConfig(32, 24, camera, light, {{"mode", "brute_force"}, {"samples", 64}}),
                                test::planeScene());
        size_t ground = 0;
        for (size_t i = 0; i < f.pixels(); ++i) {
            if (!f.hasGeometry(i)) continue;
            // Up to V_l's storage: R16_UNORM, half a step of 1/65535 (0.5 is 32768 / 65535).
            EXPECT_GE(f.visibility[i], lowest - 0.5f / 65535.0f) << "pixel " << i << ", light at y = " << light.position.y;
            EXPECT_LE(f.visibility[i], highest + 0.5f / 65535.0f) << "pixel " << i << ", light at y = " << light.position.y;
            ++ground;
        }
        EXPECT_GT(ground, 500u);
    }
    // The rays: exactly half of the straddling light's samples (stratified in y) are above.
    const Frame& traced = render(referenceConfig(32, 24, camera, straddling, {{"samples", 64}}), test::planeScene());
    for (size_t i = 0; i < traced.pixels(); ++i) EXPECT_NEAR(traced.visibility[i], 0.5f, 0.5f / 65535.0f) << "pixel " << i;
}

// An animated frame: the maps follow a moving light (Technique::update rewrites every
// sample's frusta and data) and moved casters (drawn where they are now), giving the
// image a fresh renderer gives.
TEST_F(ReferenceBruteForce, FollowsAMovingLightAndMovedCasters)
{
    const config::RenderConfig cfg = smallRectConfig({{"mode", "brute_force"}, {"samples", 16}});
    Frame& frame = render(cfg, scene::generatePenumbra({}));
    std::vector<float> before = frame.visibility;
    frame.config.lights[0].light.position.x += 0.5f;
    frame.renderer.update(frame.config, frame.scene, {});
    frame.render();
    EXPECT_NE(frame.visibility, before);
    EXPECT_EQ(render(frame.config, frame.scene).visibility, frame.visibility);

    before = frame.visibility;
    ASSERT_NO_FATAL_FAILURE(frame.moveOccluder({0.4f, 0.0f, 0.0f}));
    EXPECT_NE(frame.visibility, before);
    EXPECT_EQ(render(frame.config, frame.scene).visibility, frame.visibility);
}

// Translucent casters in the raster path: alpha-masked holes are cut in every map, as
// traced; an alpha-blended pane (alpha 0.3) is opaque in a depth map, so behind it V is
// 0 where the rays give 0.7 (README.md, "What it cannot do that the rays do").
TEST_F(ReferenceBruteForce, MaskHolesLetLightThroughAndBlendedCastersAreOpaque)
{
    const config::RenderConfig masked = test::halfMaskedQuadConfig();
    config::RenderConfig cfg = referenceConfig(64, 48, masked.camera, masked.lights[0].light, {{"mode", "brute_force"}});
    expectHalfMaskedQuadShadow(render(cfg, test::halfMaskedQuadScene()));

    scene::Light light;
    light.type = scene::LightType::Point;
    light.position = {3.0f, 4.0f, 0.0f};
    const Frame& g = render(referenceConfig(64, 48, lookDown({-2.5f, 6.0f, 0.001f}, {-2.5f, 0.0f, 0.0f}, 40.0f), light,
                                            {{"mode", "brute_force"}}),
                            test::panesScene({1.0f}, 0.3f));
    size_t behindPane = 0;
    for (size_t i = 0; i < g.pixels(); ++i) {
        const glm::dvec3 p = g.position(i);
        if (!g.hasGeometry(i) || p.y > 0.1) continue;
        const glm::dvec3 at = p + (glm::dvec3(light.position) - p) * (1.0 / light.position.y);
        const double inside = 1.0 - std::max(std::abs(at.x), std::abs(at.z));
        if (inside < 0.03) continue;
        EXPECT_EQ(g.visibility[i], 0.0f) << "pixel " << i;
        ++behindPane;
    }
    EXPECT_GT(behindPane, 50u);
}

// Bad input names the plugin and the parameter: a map too large for the device, more
// maps than brute_force takes, a resolution out of the declared range.
TEST_F(ReferencePlugin, BruteForceBadInputNamesThePluginAndTheParameter)
{
    scene::Light light;
    light.type = scene::LightType::Rect;
    light.position = {0.0f, 4.0f, 0.0f};
    light.direction = {0.0f, -1.0f, 0.0f};
    light.tangent = {1.0f, 0.0f, 0.0f};
    light.sizeWorld = {0.8f, 0.5f};
    const uint32_t maxDimension = context->properties().limits.maxImageDimension2D;
    const uint32_t tooLarge = maxDimension / 3 + 1;  // a cube atlas is 3 faces wide
    ASSERT_LE(tooLarge, 8192u) << "this device's images are larger than map_resolution's range";
    const scene::Camera camera = lookDown({0.0f, 5.0f, 0.1f}, {0.0f, 0.0f, 0.0f}, 40.0f);
    const std::pair<nlohmann::json, std::string> cases[] = {
        {{{"mode", "brute_force"}, {"map_resolution", tooLarge}}, "map_resolution"},
        {{{"mode", "brute_force"}, {"samples", 5000}}, "samples"},
    };
    for (const auto& [params, name] : cases) {
        try {
            render(referenceConfig(32, 24, camera, light, params), scene::generatePenumbra(analyticParams(1.0f)));
            ADD_FAILURE() << "no error for " << params.dump();
        } catch (const std::exception& e) {
            EXPECT_NE(std::string(e.what()).find("reference"), std::string::npos) << e.what();
            EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
        }
    }
    plugin::ParamValues values = test::plugins().load("reference").defaultParams();
    try {
        values.set("map_resolution", 8, "--set reference.map_resolution");
        ADD_FAILURE() << "map_resolution 8 accepted";
    } catch (const ConfigError& e) {
        EXPECT_NE(std::string(e.what()).find("reference.map_resolution"), std::string::npos) << e.what();
    }
}

} // namespace
