// Batched scene draws (render::SceneGpu, "draw_batching"): a frame drawn with instanced,
// indirect multi-draws is the frame drawn with one draw per instance, with every culling
// mode (the visibility service's instance masks split batches into runs) and with
// alpha-masked casters on two textures (draws grouped by texture).
#include "TestConfigs.h"
#include "TestContext.h"

#include "penumbra/config/Config.h"
#include "penumbra/frame/FrameRenderer.h"
#include "penumbra/scene/Scene.h"

#include <gtest/gtest.h>

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>

using namespace penumbra;

namespace {

// test::halfMaskedQuadScene (ground and a half-transparent alpha-masked quad) with more:
// repeated boxes and quads on a second masked texture, interleaved in instance order so
// that batching reorders them, spread so that culling keeps some and drops others.
scene::Scene repeatedMeshesScene()
{
    scene::Scene s = test::halfMaskedQuadScene();
    scene::Texture stripes{"stripes", 4, 4, std::vector<uint8_t>(4 * 4 * 4, 180)};
    for (int i = 0; i < 16; ++i) stripes.rgba[4 * i + 3] = (i % 2) ? 255 : 0;
    s.textures.push_back(stripes);
    s.materials.push_back({"striped", {0.9f, 0.6f, 0.3f, 1.0f}, 1, scene::AlphaMode::Mask, 0.5f, true});
    scene::Mesh box = scene::makeBox("box");
    scene::Mesh stripedQuad = scene::makePlane("striped quad");
    stripedQuad.material = 2;
    const uint32_t boxMesh = test::addMesh(s, box), stripedMesh = test::addMesh(s, stripedQuad);
    const glm::mat4 identity(1.0f);
    for (int i = 0; i < 12; ++i) {
        const float x = -7.0f + 1.3f * float(i), z = (i % 3 - 1) * 3.5f;
        test::addInstance(s, boxMesh, "box" + std::to_string(i),
                          glm::scale(glm::translate(identity, {x, 0.4f + 0.1f * float(i % 4), z}), glm::vec3(0.8f)));
        if (i % 2 == 0)
            test::addInstance(s, i % 4 == 0 ? stripedMesh : 1u, "quad" + std::to_string(i),
                              glm::scale(glm::translate(identity, {x, 1.2f + 0.2f * float(i % 3), -z}), glm::vec3(1.5f, 1, 1.5f)));
    }
    return s;
}

struct Frame {
    std::vector<float> visibility;
    std::vector<uint8_t> color;
    visibility::CullingStats culling;
};

Frame renderFrame(gpu::Context& context, const scene::Scene& scene, config::RenderConfig cfg, bool batched)
{
    cfg.batchDraws = batched;
    frame::FrameRenderer renderer(context, scene, cfg, test::plugins());
    // Two frames: the culling modes reuse what the first found (multi-queries, fall-backs).
    renderer.renderFrame();
    const frame::FrameTimings t = renderer.renderFrame();
    return {renderer.readVisibility(0), renderer.readColor(), t.culling};
}

class BatchedDraws : public test::GpuTest, public ::testing::WithParamInterface<config::CullingMode> {};

TEST_P(BatchedDraws, FrameEqualsOneDrawPerInstance)
{
    const scene::Scene scene = repeatedMeshesScene();
    config::RenderConfig cfg = test::halfMaskedQuadConfig();
    cfg.width = 160;
    cfg.height = 120;
    cfg.camera.position = {2.0f, 11.0f, 6.0f};
    cfg.culling = GetParam();
    const Frame batched = renderFrame(*context, scene, cfg, true);
    const Frame perInstance = renderFrame(*context, scene, cfg, false);
    ASSERT_EQ(batched.visibility.size(), perInstance.visibility.size());
    size_t shadowed = 0, lit = 0;
    float maxDiff = 0.0f;
    for (size_t i = 0; i < batched.visibility.size(); ++i) {
        maxDiff = std::max(maxDiff, std::abs(batched.visibility[i] - perInstance.visibility[i]));
        shadowed += perInstance.visibility[i] < 0.5f;
        lit += perInstance.visibility[i] > 0.5f;
    }
    // The scene casts shadows in view, and batching changes none of them: depth-only draws
    // do not depend on draw order.
    EXPECT_GT(shadowed, 500u);
    EXPECT_GT(lit, 500u);
    EXPECT_EQ(maxDiff, 0.0f);
    EXPECT_EQ(batched.color, perInstance.color);
    // The same casters drawn: the visibility service's counts are exact either way.
    EXPECT_EQ(batched.culling.castersDrawn, perInstance.culling.castersDrawn);
    EXPECT_EQ(batched.culling.trianglesDrawn, perInstance.culling.trianglesDrawn);
    EXPECT_EQ(batched.culling.receivers, perInstance.culling.receivers);
    test::expectNoValidationMessages(*context);
}

// Draws of untextured materials use the G-buffer's (and the floor's) pipeline without
// the base-colour sample (frame/BaseColorPipelines.h); giving those materials an
// explicit white texture of their own sends them through the textured variant, and the
// frame is the same, byte for byte (a sample of white is exactly 1).
TEST_F(BatchedDraws, UntexturedVariantDrawsWhatAWhiteTextureDraws)
{
    const scene::Scene scene = repeatedMeshesScene();
    scene::Scene whiteTextured = scene;
    const auto white = int32_t(whiteTextured.textures.size());
    whiteTextured.textures.push_back({"white", 1, 1, {255, 255, 255, 255}});
    size_t retextured = 0;
    for (scene::Material& m : whiteTextured.materials) {
        if (m.baseColorTexture != scene::kNoTexture) continue;
        m.baseColorTexture = white;
        ++retextured;
    }
    ASSERT_GT(retextured, 0u) << "the scene has no untextured material to compare";
    config::RenderConfig cfg = test::halfMaskedQuadConfig();
    cfg.width = 160;
    cfg.height = 120;
    cfg.camera.position = {2.0f, 11.0f, 6.0f};
    const Frame untextured = renderFrame(*context, scene, cfg, true);
    const Frame textured = renderFrame(*context, whiteTextured, cfg, true);
    EXPECT_EQ(untextured.color, textured.color);
    EXPECT_EQ(untextured.visibility, textured.visibility);
    test::expectNoValidationMessages(*context);
}

INSTANTIATE_TEST_SUITE_P(CullingModes, BatchedDraws,
                         ::testing::Values(config::CullingMode::None, config::CullingMode::Frustum,
                                           config::CullingMode::LightOcclusion, config::CullingMode::ReceiverMask),
                         [](const auto& info) {
                             std::string name = config::cullingModeName(info.param);
                             name.erase(std::remove(name.begin(), name.end(), '-'), name.end());
                             return name;
                         });

} // namespace
