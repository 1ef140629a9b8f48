// The floor (frame/FloorRenderer.h): a real forward render of the config's scene. Its
// shadowed image must match the frame's own image (same lights, Lambert and hard shadow
// map) and be darker than its unshadowed image exactly where the frame's visibility
// image says the light is blocked; its passes must be timed.
#include "TestConfigs.h"
#include "TestContext.h"

#include "penumbra/config/Config.h"
#include "penumbra/frame/FloorRenderer.h"
#include "penumbra/frame/FrameRenderer.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

using namespace penumbra;

namespace {

class Floor : public test::GpuTest {};
class FloorOfLight : public test::GpuTest, public ::testing::WithParamInterface<scene::LightType> {};

// Mean of the RGB channels of pixel `p` (sRGB bytes).
float luminance(const std::vector<uint8_t>& rgba, size_t p)
{
    return (float(rgba[4 * p]) + float(rgba[4 * p + 1]) + float(rgba[4 * p + 2])) / 3.0f;
}

} // namespace

// A spot light (one perspective face), a directional light (one orthographic face: both
// take the vertex shader's shadow coordinates) and a point light (a cube atlas: the face
// is chosen per fragment).
TEST_P(FloorOfLight, ShadowsFallWhereTheFramesVisibilityIsZeroAndTheImagesAgree)
{
    config::RenderConfig cfg = test::defaultTestConfig();
    test::setLightType(cfg.lights[0], GetParam());
    const scene::Scene scene = config::buildScene(cfg.scene);
    frame::FrameRenderer frameRenderer(*context, scene, cfg, test::plugins());
    frameRenderer.renderFrame();
    const std::vector<float> visibility = frameRenderer.readVisibility(0);
    const std::vector<uint8_t> frameColor = frameRenderer.readColor();

    frame::FloorRenderer floor(*context, scene, cfg);
    EXPECT_EQ(floor.shadowResolution(0), 2048u);  // config/default.json's
    const frame::FrameTimings timings = floor.renderFrame();
    const std::vector<uint8_t> shadowed = floor.readColor(true), unshadowed = floor.readColor(false);
    ASSERT_EQ(shadowed.size(), frameColor.size());
    ASSERT_EQ(unshadowed.size(), frameColor.size());

    // Every pass ran and took GPU time.
    std::vector<std::string> names;
    for (const frame::PassTiming& p : timings.passes) {
        names.push_back(p.name);
        EXPECT_GT(p.gpuMs, 0.0) << p.name;
    }
    EXPECT_EQ(names, (std::vector<std::string>{frame::floorShadowMapPass(0), std::string(frame::kFloorShadowedForward),
                                               std::string(frame::kFloorUnshadowedForward)}));

    const size_t pixels = size_t(cfg.width) * cfg.height;
    size_t inShadow = 0, darkerInShadow = 0, lit = 0, sameWhenLit = 0, agree = 0;
    double absDiff = 0.0;
    for (size_t p = 0; p < pixels; ++p) {
        const float withShadow = luminance(shadowed, p), without = luminance(unshadowed, p);
        const float frame = luminance(frameColor, p);
        absDiff += std::abs(withShadow - frame);
        if (std::abs(withShadow - frame) <= 6.0f) ++agree;
        // Where the light would reach (the floor unshadowed is brighter than the frame
        // there): surfaces that face away have V = 0 too, but no light to lose.
        if (visibility[p] == 0.0f && without > frame + 10.0f) {
            ++inShadow;
            if (withShadow < without - 10.0f) ++darkerInShadow;
        } else if (visibility[p] == 1.0f) {
            ++lit;
            if (std::abs(withShadow - without) <= 1.0f) ++sameWhenLit;
        }
    }
    // The default view shows the boxes' and the sphere's shadows.
    ASSERT_GT(inShadow, pixels / 100);
    ASSERT_GT(lit, pixels / 10);
    // The floor's compare and the hard technique's sample the same map projection with
    // the same bias: they differ only along shadow edges (the frame's G-buffer positions
    // are interpolated in another precision than the forward pass's).
    EXPECT_GT(double(darkerInShadow), 0.98 * double(inShadow)) << darkerInShadow << " of " << inShadow;
    EXPECT_GT(double(sameWhenLit), 0.98 * double(lit)) << sameWhenLit << " of " << lit;
    EXPECT_GT(double(agree), 0.98 * double(pixels)) << agree << " of " << pixels;
    EXPECT_LT(absDiff / double(pixels), 1.0);
}

INSTANTIATE_TEST_SUITE_P(Lights, FloorOfLight,
                         ::testing::Values(scene::LightType::Spot, scene::LightType::Directional, scene::LightType::Point),
                         [](const ::testing::TestParamInfo<scene::LightType>& info) {
                             return std::string(scene::lightTypeName(info.param));
                         });

TEST_F(Floor, FollowsAnAnimatedLightAndTakesTheConfigsResolution)
{
    config::RenderConfig cfg = test::defaultTestConfig();
    cfg.lights[0].shadow.setParam("resolution", 512, "test");
    const scene::Scene scene = config::buildScene(cfg.scene);
    frame::FloorRenderer floor(*context, scene, cfg);
    EXPECT_EQ(floor.shadowResolution(0), 512u);
    floor.renderFrame();
    const std::vector<uint8_t> before = floor.readColor(true);
    // Turn the spot away from the scene: no shadow, no light from it; the image changes.
    cfg.lights[0].light.direction = {0.0f, 1.0f, 0.0f};
    floor.update(cfg, scene, {});
    floor.renderFrame();
    const std::vector<uint8_t> after = floor.readColor(true), unshadowed = floor.readColor(false);
    size_t changed = 0, sameAsUnshadowed = 0;
    for (size_t p = 0; p < before.size() / 4; ++p) {
        if (std::abs(luminance(before, p) - luminance(after, p)) > 10.0f) ++changed;
        if (std::abs(luminance(after, p) - luminance(unshadowed, p)) <= 1.0f) ++sameAsUnshadowed;
    }
    EXPECT_GT(changed, before.size() / 4 / 10);
    EXPECT_EQ(sameAsUnshadowed, before.size() / 4);  // a light that lights nothing shadows nothing
}

TEST_F(Floor, RejectsAResolutionThatIsNoWholeNumber)
{
    config::RenderConfig cfg = test::defaultTestConfig();
    cfg.lights[0].shadow.setParam("resolution", 8, "scene.json: /lights/0/shadow/resolution");
    const scene::Scene scene = config::buildScene(cfg.scene);
    try {
        frame::FloorRenderer floor(*context, scene, cfg);
        FAIL() << "no error";
    } catch (const ConfigError& e) {
        EXPECT_NE(std::string(e.what()).find("scene.json: /lights/0/shadow/resolution: floor of light 0: resolution must "
                                             "be a whole number in [16, 65536], got 8"),
                  std::string::npos)
            << e.what();
    }
}
