// The first frame, end to end: configs rendered headless, each light's visibility image
// checked against the scene's geometry by an independent CPU ray caster.
#include "RayCastAgreement.h"
#include "TestConfigs.h"
#include "TestContext.h"

#include "penumbra/config/Config.h"
#include "penumbra/core/Error.h"
#include "penumbra/frame/FrameRenderer.h"
#include "penumbra/gpu/Resources.h"

#include <gtest/gtest.h>

#include <glm/gtc/matrix_transform.hpp>

#include <cmath>

using namespace penumbra;

namespace {

// One rendered frame and what the tests read back from it.
struct RenderedFrame {
    RenderedFrame(gpu::Context& context, const config::RenderConfig& cfg)
        : config(cfg), scene(config::buildScene(cfg.scene)), renderer(context, scene, cfg, test::plugins())
    {
        renderer.renderFrame();
        positions = renderer.readPositions();
        normals = renderer.readNormals();
    }
    bool hasGeometry(size_t pixel) const { return positions[4 * pixel + 3] != 0.0f; }

    config::RenderConfig config;
    scene::Scene scene;
    frame::FrameRenderer renderer;
    std::vector<float> positions;
    std::vector<float> normals;
};

// V_l of light `l` against rays from the light (support/RayCastAgreement.h), pixels
// within two shadow-map texels of an edge in the light's view left out.
test::RayCastAgreement compareWithRayCast(const RenderedFrame& frame, size_t l, uint32_t stride = 2)
{
    const std::vector<float> visibility = frame.renderer.readVisibility(l);
    const nlohmann::json* resolutionParam = frame.config.lights[l].shadow.param("resolution");
    const uint32_t resolution = resolutionParam ? resolutionParam->get<uint32_t>() : 2048u;
    const test::LightRayClassifier classifier(frame.scene, frame.config.lights[l].light, render::shadowFrusta(frame.config.lights[l].light, frame.scene.bounds()),
                                              resolution);
    const test::FrameImages images{frame.positions, frame.normals, visibility, frame.config.width, frame.config.height};
    return test::compareWithRayCast(classifier, images, {stride, 2.0, 0.0f, "light " + std::to_string(l)});
}

// config/default.json at a scene scale (the test parameter).
class DefaultRender : public test::GpuTest, public ::testing::WithParamInterface<float> {
protected:
    void SetUp() override
    {
        test::GpuTest::SetUp();
        config::RenderConfig cfg = test::defaultTestConfig();
        test::scaleConfig(cfg, GetParam());
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
    const test::RayCastAgreement a = compareWithRayCast(*frame, 0);
    EXPECT_EQ(a.mismatches, 0u);
    // Enough of both classes that the comparison means something.
    EXPECT_GT(a.surelyShadowed, 500u);
    EXPECT_GT(a.surelyLit, 5000u);
}

TEST_P(DefaultRender, ColorImageHasShadowsDarkerThanLitGround)
{
    const std::vector<uint8_t> color = frame->renderer.readColor();
    ASSERT_EQ(color.size(), visibility.size() * 4);
    // Mean luminance of ground pixels (y ~ 0) in and out of shadow, inside the spot.
    double lit = 0.0, shadow = 0.0;
    size_t nLit = 0, nShadow = 0;
    const glm::mat4 lightViewProj =
        render::shadowFrusta(frame->config.lights[0].light, frame->scene.bounds()).front().viewProj;
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
    config::RenderConfig cfg = test::defaultTestConfig();
    config::LightConfig second = cfg.lights[0];
    second.light.position = {12.0f, 14.0f, -8.0f};
    second.light.direction = glm::normalize(glm::vec3(0.0f) - second.light.position);
    second.shadow.setParam("resolution", 1024, "test");
    cfg.lights.push_back(second);
    const RenderedFrame frame(*context, cfg);
    ASSERT_EQ(frame.renderer.lightCount(), 2u);

    for (size_t l = 0; l < 2; ++l) {
        const test::RayCastAgreement a = compareWithRayCast(frame, l);
        EXPECT_EQ(a.mismatches, 0u) << "light " << l;
        EXPECT_GT(a.surelyShadowed, 300u) << "light " << l;
        EXPECT_GT(a.surelyLit, 3000u) << "light " << l;
    }
    const std::vector<float> v0 = frame.renderer.readVisibility(0), v1 = frame.renderer.readVisibility(1);
    size_t differ = 0;
    for (size_t i = 0; i < v0.size(); ++i) differ += v0[i] != v1[i];
    EXPECT_GT(differ, v0.size() / 20);
}

// The pixel inspector's read: one texel of the colour and of each V, equal to that pixel
// of the whole images, at the corners and across the frame, for a shadowed light and an
// unshadowed one ("none": V = 1); outside the frame, an error naming the pixel.
TEST_F(MultiLight, ReadPixelIsThatPixelOfTheWholeImages)
{
    config::RenderConfig cfg = test::defaultTestConfig();
    config::LightConfig unshadowed = cfg.lights[0];
    unshadowed.name = "unshadowed";
    unshadowed.shadow = {};
    unshadowed.shadow.technique = "none";
    cfg.lights.push_back(unshadowed);
    const RenderedFrame frame(*context, cfg);
    const uint32_t w = frame.renderer.width(), h = frame.renderer.height();
    const std::vector<uint8_t> color = frame.renderer.readColor();
    const std::vector<float> v0 = frame.renderer.readVisibility(0), v1 = frame.renderer.readVisibility(1);
    size_t shadowed = 0;
    for (uint32_t y = 0; y < h; y += std::max(1u, h / 13)) {
        for (const uint32_t x : {0u, w / 3, w / 2 + 1, w - 1}) {
            for (const uint32_t py : {y, h - 1 - y}) {
                const frame::FrameRenderer::Pixel p = frame.renderer.readPixel(x, py);
                const size_t i = size_t(py) * w + x;
                for (size_t c = 0; c < 4; ++c) EXPECT_EQ(p.color[c], color[i * 4 + c]) << x << ", " << py;
                ASSERT_EQ(p.visibility.size(), 2u);
                EXPECT_EQ(p.visibility[0], v0[i]) << x << ", " << py;
                EXPECT_EQ(p.visibility[1], 1.0f);
                shadowed += v0[i] < 0.5f;
            }
        }
    }
    EXPECT_GT(shadowed, 0u);  // the sweep met a shadow
    EXPECT_THROW((void)frame.renderer.readPixel(w, 0), Error);
    EXPECT_THROW((void)frame.renderer.readPixel(0, h), Error);
    // gpu::readImage's own guard: a rectangle that leaves the image, or an empty one.
    const gpu::Image& image = frame.renderer.executor().image("color");
    const VkImageLayout layout = frame.renderer.executor().finalLayout("color");
    EXPECT_THROW((void)gpu::readImage(*context, image, layout, VkRect2D{{int32_t(w) - 1, 0}, {2, 1}}), GpuError);
    EXPECT_THROW((void)gpu::readImage(*context, image, layout, VkRect2D{{-1, 0}, {1, 1}}), GpuError);
    EXPECT_THROW((void)gpu::readImage(*context, image, layout, VkRect2D{{0, 0}, {0, 1}}), GpuError);
    EXPECT_EQ(gpu::readImage(*context, image, layout, VkRect2D{{0, 0}, {w, 2}}).size(), size_t(w) * 2 * 4);
}

// Every light type's hard shadow against the ray cast: a directional light (orthographic
// map), a point light above the grid and rect and disk lights (six cube faces around the
// centre), all in the default scene.
class LightTypes : public test::GpuTest, public ::testing::WithParamInterface<scene::LightType> {};

TEST_P(LightTypes, VisibilityMatchesRayCastGeometry)
{
    config::RenderConfig cfg = test::defaultTestConfig();
    test::setLightType(cfg.lights[0], GetParam());
    cfg.lights[0].shadow.setParam("resolution", GetParam() == scene::LightType::Directional ? 2048 : 1024, "test");
    const RenderedFrame frame(*context, cfg);
    EXPECT_EQ(render::shadowFrusta(frame.config.lights[0].light, frame.scene.bounds()).size(),
              GetParam() == scene::LightType::Directional ? 1u : 6u);
    const test::RayCastAgreement a = compareWithRayCast(frame, 0);
    EXPECT_EQ(a.mismatches, 0u);
    EXPECT_GT(a.surelyShadowed, 300u);
    EXPECT_GT(a.surelyLit, 3000u);
}

INSTANTIATE_TEST_SUITE_P(Hard, LightTypes,
                         ::testing::Values(scene::LightType::Directional, scene::LightType::Point, scene::LightType::Rect,
                                           scene::LightType::Disk),
                         [](const ::testing::TestParamInfo<scene::LightType>& info) {
                             return std::string(scene::lightTypeName(info.param));
                         });

TEST_F(MultiLight, AnimatedLightAndNodeFollowTheirTracks)
{
    // A script moves the light and one box; every frame's visibility must match the ray
    // cast of that frame's geometry (the renderer must pick up both moves).
    config::RenderConfig cfg = test::defaultTestConfig();
    config::AnimationTrack light{"/lights/0/position", config::Interpolation::Linear,
                                 {{0.0f, {-9.0f, 16.0f, 7.0f}}, {1.0f, {9.0f, 14.0f, -6.0f}}}};
    config::AnimationTrack box{"node:box_2_2/translation", config::Interpolation::Smooth,
                               {{0.0f, {0.0f, 1.0f, 0.0f}}, {0.5f, {3.0f, 3.0f, 1.5f}}, {1.0f, {-4.0f, 2.0f, 5.0f}}}};
    cfg.animation.tracks = {light, box};
    cfg.lights[0].target = glm::vec3(1.5f, 0.0f, 0.0f);
    RenderedFrame frame(*context, cfg);
    for (float t : {0.5f, 1.0f}) {
        config::applyAnimation(cfg.animation, t, frame.config, frame.scene);
        const std::vector<uint32_t> moved = frame.scene.updateTransforms();
        EXPECT_EQ(moved.size(), 1u);
        frame.renderer.update(frame.config, frame.scene, moved);
        frame.renderer.renderFrame();
        frame.positions = frame.renderer.readPositions();
        frame.normals = frame.renderer.readNormals();
        const test::RayCastAgreement a = compareWithRayCast(frame, 0);
        EXPECT_EQ(a.mismatches, 0u) << "t = " << t;
        EXPECT_GT(a.surelyShadowed, 300u) << "t = " << t;
    }
}

class Materials : public test::GpuTest {};

TEST_F(Materials, AlphaMaskCutsHolesInSurfacesAndShadows)
{
    // test::halfMaskedQuadScene: light reaches x in (-1, 1) through the quad's
    // transparent half, its opaque half shadows x in [1, 3].
    const scene::Scene s = test::halfMaskedQuadScene();
    const config::RenderConfig cfg = test::halfMaskedQuadConfig();
    frame::FrameRenderer renderer(*context, s, cfg, test::plugins());
    renderer.renderFrame();
    const std::vector<float> positions = renderer.readPositions();
    const std::vector<float> v = renderer.readVisibility(0);

    size_t throughHole = 0, opaque = 0, inShadow = 0;
    for (size_t i = 0; i < v.size(); ++i) {
        const float x = positions[4 * i], y = positions[4 * i + 1], z = positions[4 * i + 2];
        if (positions[4 * i + 3] == 0.0f || std::abs(z) > 1.5f) continue;
        if (x > -0.8f && x < -0.2f) {
            ASSERT_NEAR(y, 0.0f, 1e-3f) << "the camera sees the ground through the hole at x = " << x;
            ASSERT_EQ(v[i], 1.0f) << "light passes through the hole onto x = " << x;
            ++throughHole;
        } else if (x > 0.3f && x < 1.7f) {
            ASSERT_NEAR(y, 2.0f, 1e-3f) << "the opaque half is seen at x = " << x;
            ++opaque;
        } else if (x > 2.2f && x < 2.8f) {
            ASSERT_NEAR(y, 0.0f, 1e-3f);
            ASSERT_EQ(v[i], 0.0f) << "the opaque half shadows the ground at x = " << x;
            ++inShadow;
        }
    }
    EXPECT_GT(throughHole, 50u);
    EXPECT_GT(opaque, 100u);
    EXPECT_GT(inShadow, 100u);
}
