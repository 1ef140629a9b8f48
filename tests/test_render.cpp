// The first frame, end to end: the default config rendered headless, its visibility
// image checked against the scene's geometry by an independent CPU ray caster.
#include "RayCast.h"
#include "TestContext.h"

#include "penumbra/config/Config.h"
#include "penumbra/render/FrameRenderer.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace penumbra;

namespace {

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

// Renders config/default.json at a scene scale (the test parameter).
class DefaultRender : public test::GpuTest, public ::testing::WithParamInterface<float> {
protected:
    void SetUp() override
    {
        test::GpuTest::SetUp();
        config = config::loadConfig(std::filesystem::path(PENUMBRA_SOURCE_DIR) / "config/default.json");
        // Small image, full-size shadow map: the test checks the technique, not the
        // output resolution.
        config.width = 320;
        config.height = 180;
        scaleConfig(config, GetParam());
        scene = config::buildScene(config.scene);
        renderer = std::make_unique<render::FrameRenderer>(*context, scene, config);
        renderer->renderFrame();
        visibility = renderer->readVisibility(0);
        positions = renderer->readPositions();
        normals = renderer->readNormals();
    }
    void TearDown() override
    {
        renderer.reset();
        test::GpuTest::TearDown();
    }

    config::RenderConfig config;
    scene::Scene scene;
    std::unique_ptr<render::FrameRenderer> renderer;
    std::vector<float> visibility;
    std::vector<float> positions;
    std::vector<float> normals;
};

} // namespace

TEST_P(DefaultRender, VisibilityIsFiniteAndInUnitRange)
{
    ASSERT_EQ(visibility.size(), size_t(config.width) * config.height);
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
        if (positions[4 * i + 3] == 0.0f) {
            ++background;
            ASSERT_EQ(visibility[i], 1.0f) << "pixel " << i;
        }
    }
    EXPECT_GT(background, 0u);  // the default camera sees sky
}

TEST_P(DefaultRender, VisibilityMatchesRayCastGeometry)
{
    // Cast a segment from every pixel's G-buffer surface point to the light. A pixel
    // counts as surely shadowed (or surely lit) only when it and its 8 neighbours agree:
    // pixels at a shadow edge are ambiguous at any finite shadow-map resolution (a pixel
    // here spans several shadow-map texels, so one pixel of margin is enough). Surfaces
    // within ~6 degrees of grazing (|N.L| < 0.1) are left out: there a hard shadow map
    // either acnes or, with the slope bias that prevents it, leaks, and shading weights
    // the light by max(N.L, 0) ~ 0 anyway. The grazing-light issue tests them on purpose.
    const test::RayCaster caster(scene);
    const scene::Light& light = config.lights[0].light;
    const double epsilon = 1e-4 * scene.bounds().radius();  // lifts the segment off its own surface
    const glm::mat4 lightViewProj = renderer->lightFrustum(0).viewProj;
    const glm::dvec3 lightPos(light.position);
    const uint32_t w = config.width, h = config.height;

    enum : int8_t { kUnknown = -1, kLit = 0, kBlocked = 1 };
    std::vector<int8_t> blocked(size_t(w) * h, kUnknown);
    for (size_t i = 0; i < blocked.size(); ++i) {
        if (positions[4 * i + 3] == 0.0f) continue;
        const glm::dvec3 p(positions[4 * i], positions[4 * i + 1], positions[4 * i + 2]);
        // Only points well inside the light's frustum: outside it V is 1 by contract.
        const glm::vec4 clip = lightViewProj * glm::vec4(glm::vec3(p), 1.0f);
        if (clip.w <= 0.0f) continue;
        const glm::vec2 uv = glm::vec2(clip) / clip.w * 0.5f + 0.5f;
        if (glm::any(glm::lessThan(uv, glm::vec2(0.02f))) || glm::any(glm::greaterThan(uv, glm::vec2(0.98f)))) continue;
        const glm::dvec3 toLight = glm::normalize(lightPos - p);
        const glm::dvec3 n(normals[4 * i], normals[4 * i + 1], normals[4 * i + 2]);
        if (std::abs(glm::dot(glm::normalize(n), toLight)) < 0.1) continue;
        const glm::dvec3 start = p + epsilon * toLight;
        blocked[i] = caster.segmentBlocked(start, lightPos) ? kBlocked : kLit;
    }

    size_t surelyShadowed = 0, surelyLit = 0, mismatches = 0;
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
            const float v = visibility[i];
            const float expected = centre == kBlocked ? 0.0f : 1.0f;
            (centre == kBlocked ? surelyShadowed : surelyLit)++;
            if (v != expected && ++mismatches <= 10) {
                ADD_FAILURE() << "pixel (" << x << ", " << y << ") at (" << positions[4 * i] << ", "
                              << positions[4 * i + 1] << ", " << positions[4 * i + 2] << "): ray cast says "
                              << (centre == kBlocked ? "shadowed" : "lit") << " but V = " << v;
            }
        }
    }
    EXPECT_EQ(mismatches, 0u);
    // Enough of both classes that the comparison means something.
    EXPECT_GT(surelyShadowed, 2000u);
    EXPECT_GT(surelyLit, 10000u);
}

TEST_P(DefaultRender, ColorImageHasShadowsDarkerThanLitGround)
{
    const std::vector<uint8_t> color = renderer->readColor();
    ASSERT_EQ(color.size(), size_t(config.width) * config.height * 4);
    // Mean luminance of ground pixels (y ~ 0) in and out of shadow, inside the spot.
    double lit = 0.0, shadow = 0.0;
    size_t nLit = 0, nShadow = 0;
    const glm::mat4 lightViewProj = renderer->lightFrustum(0).viewProj;
    for (size_t i = 0; i < visibility.size(); ++i) {
        if (positions[4 * i + 3] == 0.0f || std::abs(positions[4 * i + 1]) > 1e-3f) continue;
        const glm::vec4 clip = lightViewProj * glm::vec4(positions[4 * i], positions[4 * i + 1], positions[4 * i + 2], 1.0f);
        const glm::vec2 ndc = glm::vec2(clip) / clip.w;
        if (glm::length(ndc) > 0.5f) continue;  // well inside the spot cone
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
