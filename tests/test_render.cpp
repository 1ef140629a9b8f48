// The first frame, end to end: configs rendered headless, each light's visibility image
// checked against the scene's geometry by an independent CPU ray caster.
#include "RayCast.h"
#include "TestContext.h"

#include "penumbra/config/Config.h"
#include "penumbra/render/FrameRenderer.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace penumbra;

namespace {

config::RenderConfig defaultConfig()
{
    config::RenderConfig c = config::loadConfig(std::filesystem::path(PENUMBRA_SOURCE_DIR) / "config/default.json");
    // Small image, full-size shadow map: the tests check the technique, not the output
    // resolution.
    c.width = 320;
    c.height = 180;
    return c;
}

// The same scene and view at another scale: every length times s, intensities times s²
// so that irradiance (I / d²) and the image stay the same. Nothing in the engine may
// depend on absolute units.
void scaleConfig(config::RenderConfig& c, float s)
{
    scene::BoxGridParams& g = c.scene.boxGrid;
    for (float* length : {&g.boxSize, &g.spacing, &g.minHeight, &g.maxHeight, &g.sphereRadius, &g.planeSize}) *length *= s;
    c.camera.position *= s;
    c.camera.target *= s;
    c.camera.nearWorld *= s;
    for (config::LightConfig& l : c.lights) {
        l.light.position *= s;
        l.light.intensity *= s * s;
    }
}

// One rendered frame and what the tests read back from it.
struct RenderedFrame {
    RenderedFrame(gpu::Context& context, const config::RenderConfig& cfg)
        : config(cfg), scene(config::buildScene(cfg.scene)), renderer(context, scene, cfg)
    {
        renderer.renderFrame();
        positions = renderer.readPositions();
        normals = renderer.readNormals();
    }
    bool hasGeometry(size_t pixel) const { return positions[4 * pixel + 3] != 0.0f; }

    config::RenderConfig config;
    scene::Scene scene;
    render::FrameRenderer renderer;
    std::vector<float> positions;
    std::vector<float> normals;
};

struct RayCastAgreement {
    size_t surelyShadowed = 0;
    size_t surelyLit = 0;
    size_t mismatches = 0;
};

// Casts a segment from every pixel's G-buffer surface point to light `l` and compares
// with V_l. A pixel counts as surely shadowed (or surely lit) only when it and its 8
// neighbours agree: pixels at a shadow edge are ambiguous at any finite shadow-map
// resolution (a pixel here spans several shadow-map texels, so one pixel of margin is
// enough). Surfaces within ~6 degrees of grazing (|N.L| < 0.1) are left out: there a
// hard shadow map either acnes or, with the slope bias that prevents it, leaks, and
// shading weights the light by max(N.L, 0) ~ 0 anyway. The grazing-light issue tests
// them on purpose.
RayCastAgreement compareWithRayCast(const RenderedFrame& frame, size_t l)
{
    const std::vector<float> visibility = frame.renderer.readVisibility(l);
    const test::RayCaster caster(frame.scene);
    const double epsilon = 1e-4 * frame.scene.bounds().radius();  // lifts the segment off its own surface
    const glm::mat4 lightViewProj = frame.renderer.lightFrustum(l).viewProj;
    const glm::dvec3 lightPos(frame.config.lights[l].light.position);
    const uint32_t w = frame.config.width, h = frame.config.height;

    enum : int8_t { kUnknown = -1, kLit = 0, kBlocked = 1 };
    std::vector<int8_t> blocked(size_t(w) * h, kUnknown);
    for (size_t i = 0; i < blocked.size(); ++i) {
        if (!frame.hasGeometry(i)) continue;
        const float* pos = &frame.positions[4 * i];
        const glm::dvec3 p(pos[0], pos[1], pos[2]);
        // Only points well inside the light's frustum: outside it V is 1 by contract.
        const glm::vec4 clip = lightViewProj * glm::vec4(glm::vec3(p), 1.0f);
        if (clip.w <= 0.0f) continue;
        const glm::vec2 uv = glm::vec2(clip) / clip.w * 0.5f + 0.5f;
        if (glm::any(glm::lessThan(uv, glm::vec2(0.02f))) || glm::any(glm::greaterThan(uv, glm::vec2(0.98f)))) continue;
        const glm::dvec3 toLight = glm::normalize(lightPos - p);
        const glm::dvec3 n(frame.normals[4 * i], frame.normals[4 * i + 1], frame.normals[4 * i + 2]);
        if (std::abs(glm::dot(glm::normalize(n), toLight)) < 0.1) continue;
        blocked[i] = caster.segmentBlocked(p + epsilon * toLight, lightPos) ? kBlocked : kLit;
    }

    RayCastAgreement result;
    for (uint32_t y = 1; y + 1 < h; ++y) {
        for (uint32_t x = 1; x + 1 < w; ++x) {
            const size_t i = size_t(y) * w + x;
            const int8_t centre = blocked[i];
            if (centre == kUnknown) continue;
            bool agree = true;
            for (int dy = -1; dy <= 1 && agree; ++dy) {
                for (int dx = -1; dx <= 1 && agree; ++dx) agree = blocked[(y + dy) * size_t(w) + (x + dx)] == centre;
            }
            if (!agree) continue;
            const float expected = centre == kBlocked ? 0.0f : 1.0f;
            (centre == kBlocked ? result.surelyShadowed : result.surelyLit)++;
            if (visibility[i] != expected && ++result.mismatches <= 10) {
                ADD_FAILURE() << "light " << l << ", pixel (" << x << ", " << y << ") at (" << frame.positions[4 * i]
                              << ", " << frame.positions[4 * i + 1] << ", " << frame.positions[4 * i + 2]
                              << "): ray cast says " << (centre == kBlocked ? "shadowed" : "lit")
                              << " but V = " << visibility[i];
            }
        }
    }
    return result;
}

// config/default.json at a scene scale (the test parameter).
class DefaultRender : public test::GpuTest, public ::testing::WithParamInterface<float> {
protected:
    void SetUp() override
    {
        test::GpuTest::SetUp();
        config::RenderConfig cfg = defaultConfig();
        scaleConfig(cfg, GetParam());
        frame = std::make_unique<RenderedFrame>(*context, cfg);
        visibility = frame->renderer.readVisibility(0);
    }
    void TearDown() override
    {
        frame.reset();
        test::GpuTest::TearDown();
    }

    std::unique_ptr<RenderedFrame> frame;
    std::vector<float> visibility;
};

} // namespace

TEST_P(DefaultRender, VisibilityIsFiniteAndInUnitRange)
{
    ASSERT_EQ(visibility.size(), size_t(frame->config.width) * frame->config.height);
    size_t shadowed = 0;
    for (float v : visibility) {
        ASSERT_TRUE(std::isfinite(v));
        ASSERT_GE(v, 0.0f);
        ASSERT_LE(v, 1.0f);
        shadowed += v < 0.5f;
    }
    // The default view shows shadows, but mostly lit surfaces.
    EXPECT_GT(shadowed, visibility.size() / 50);
    EXPECT_LT(shadowed, visibility.size() / 2);
}

TEST_P(DefaultRender, BackgroundIsLit)
{
    size_t background = 0;
    for (size_t i = 0; i < visibility.size(); ++i) {
        if (!frame->hasGeometry(i)) {
            ++background;
            ASSERT_EQ(visibility[i], 1.0f) << "pixel " << i;
        }
    }
    EXPECT_GT(background, 0u);  // the default camera sees sky
}

TEST_P(DefaultRender, VisibilityMatchesRayCastGeometry)
{
    const RayCastAgreement a = compareWithRayCast(*frame, 0);
    EXPECT_EQ(a.mismatches, 0u);
    // Enough of both classes that the comparison means something.
    EXPECT_GT(a.surelyShadowed, 2000u);
    EXPECT_GT(a.surelyLit, 10000u);
}

TEST_P(DefaultRender, ColorImageHasShadowsDarkerThanLitGround)
{
    const std::vector<uint8_t> color = frame->renderer.readColor();
    ASSERT_EQ(color.size(), visibility.size() * 4);
    // Mean luminance of ground pixels (y ~ 0) in and out of shadow, inside the spot.
    double lit = 0.0, shadow = 0.0;
    size_t nLit = 0, nShadow = 0;
    const glm::mat4 lightViewProj = frame->renderer.lightFrustum(0).viewProj;
    const float groundTolerance = 1e-4f * frame->scene.bounds().radius();
    for (size_t i = 0; i < visibility.size(); ++i) {
        const float* p = &frame->positions[4 * i];
        if (!frame->hasGeometry(i) || std::abs(p[1]) > groundTolerance) continue;
        const glm::vec4 clip = lightViewProj * glm::vec4(p[0], p[1], p[2], 1.0f);
        if (glm::length(glm::vec2(clip) / clip.w) > 0.5f) continue;  // well inside the spot cone
        const double lum = 0.2126 * color[4 * i] + 0.7152 * color[4 * i + 1] + 0.0722 * color[4 * i + 2];
        if (visibility[i] == 0.0f) {
            shadow += lum;
            ++nShadow;
        } else if (visibility[i] == 1.0f) {
            lit += lum;
            ++nLit;
        }
    }
    ASSERT_GT(nLit, 100u);
    ASSERT_GT(nShadow, 100u);
    EXPECT_GT(lit / double(nLit), 3.0 * shadow / double(nShadow));
}

// 1: the default scene; 1e-3 and 1e5: the scale extremes the engine promises to handle.
INSTANTIATE_TEST_SUITE_P(Scales, DefaultRender, ::testing::Values(1.0f, 1e-3f, 1e5f),
                         [](const ::testing::TestParamInfo<float>& info) {
                             return info.param == 1.0f ? std::string("unit")
                                                       : info.param < 1.0f ? std::string("milli") : std::string("e5");
                         });

class MultiLight : public test::GpuTest {};

TEST_F(MultiLight, EachLightHasItsOwnVisibilityImage)
{
    // A second spot light from the opposite side: its shadows fall the other way, so the
    // two visibility images must differ, and each must match its own light's geometry.
    config::RenderConfig cfg = defaultConfig();
    config::LightConfig second = cfg.lights[0];
    second.light.position = {12.0f, 14.0f, -8.0f};
    second.light.direction = glm::normalize(glm::vec3(0.0f) - second.light.position);
    second.shadow.resolution = 1024;
    cfg.lights.push_back(second);
    const RenderedFrame frame(*context, cfg);
    ASSERT_EQ(frame.renderer.lightCount(), 2u);

    for (size_t l = 0; l < 2; ++l) {
        const RayCastAgreement a = compareWithRayCast(frame, l);
        EXPECT_EQ(a.mismatches, 0u) << "light " << l;
        EXPECT_GT(a.surelyShadowed, 1000u) << "light " << l;
        EXPECT_GT(a.surelyLit, 5000u) << "light " << l;
    }
    const std::vector<float> v0 = frame.renderer.readVisibility(0), v1 = frame.renderer.readVisibility(1);
    size_t differ = 0;
    for (size_t i = 0; i < v0.size(); ++i) differ += v0[i] != v1[i];
    EXPECT_GT(differ, v0.size() / 20);
}
