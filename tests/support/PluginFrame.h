#pragma once
// Technique plugins tested end to end: a frame rendered through render::FrameRenderer
// with the config's plugins, what the tests read back from it, and a GPU test fixture
// that owns a plugin registry (tests/test_*_plugin.cpp).
#include "RayCastAgreement.h"
#include "TestContext.h"

#include "penumbra/config/Config.h"
#include "penumbra/plugin/PluginRegistry.h"
#include "penumbra/render/FrameRenderer.h"
#include "penumbra/scene/Scene.h"

#include <cmath>
#include <memory>
#include <string>
#include <vector>

namespace penumbra::test {

// One frame rendered with plugins. Not movable: the renderer keeps references to the
// scene and the config.
struct RenderedFrame {
    RenderedFrame(gpu::Context& context, plugin::PluginRegistry& registry, const config::RenderConfig& cfg,
                  scene::Scene s);
    RenderedFrame(const RenderedFrame&) = delete;
    RenderedFrame& operator=(const RenderedFrame&) = delete;

    bool hasGeometry(size_t pixel) const { return positions[4 * pixel + 3] != 0.0f; }
    glm::vec3 position(size_t pixel) const
    {
        return {positions[4 * pixel], positions[4 * pixel + 1], positions[4 * pixel + 2]};
    }
    // Geometry at height y = 0 (the ground of test::planeScene() and the scenes built on it).
    bool onGround(size_t pixel) const { return hasGeometry(pixel) && std::abs(positions[4 * pixel + 1]) < 1e-4f; }

    // V of light `l`, checked against the contract: every value finite and in [0, 1],
    // exactly 1 where there is no geometry (the first violation fails the test).
    std::vector<float> checkedVisibility(size_t l = 0) const;

    // Light `l`'s shadow map as its plugin builds it: the same frusta (from the scene
    // bounds) and its resolution (the config's, else the plugin's default).
    LightRayClassifier classifier(size_t l) const;

    // Light 0's visibility `v` against rays from the light (compareWithRayCast, every
    // second pixel, away from edges by `bandTexels`).
    RayCastAgreement rayCastAgreement(const std::vector<float>& v, double bandTexels, float tolerance,
                                      const std::string& label) const;

    plugin::PluginRegistry& registry;
    config::RenderConfig config;
    scene::Scene scene;
    render::FrameRenderer renderer;
    std::vector<float> positions;
    std::vector<float> normals;
};

// A GPU test with a plugin registry; frames are destroyed before the registry unloads
// the libraries their techniques live in.
class PluginGpuTest : public GpuTest {
protected:
    void SetUp() override;
    void TearDown() override;
    // Renders `cfg` over `scene` into `frame` (replacing the last one).
    void render(const config::RenderConfig& cfg, scene::Scene scene);

    std::unique_ptr<plugin::PluginRegistry> registry;
    std::unique_ptr<RenderedFrame> frame;
};

} // namespace penumbra::test
