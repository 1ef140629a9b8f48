#pragma once
// Technique plugins tested end to end: a frame rendered through frame::FrameRenderer
// with the config's plugins, what the tests read back from it, and a GPU test fixture
// that owns a plugin registry (tests/test_*_plugin.cpp).
#include "RayCastAgreement.h"
#include "TestContext.h"

#include "penumbra/config/Config.h"
#include "penumbra/frame/FrameRenderer.h"
#include "penumbra/plugin/PluginRegistry.h"
#include "penumbra/scene/Scene.h"

#include <cmath>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace penumbra::test {

// One frame rendered with plugins. Not movable: the renderer keeps references to the
// scene and the config.
struct RenderedFrame {
    // `debugImages`: graph images to keep and read back (renderer.readImage).
    RenderedFrame(gpu::Context& context, plugin::PluginRegistry& registry, const config::RenderConfig& cfg,
                  scene::Scene s, const std::vector<std::string>& debugImages = {});
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
    frame::FrameRenderer renderer;
    std::vector<float> positions;
    std::vector<float> normals;
    frame::FrameTimings timings;  // the frame's (the techniques' figures, redraws)
};

// A GPU test with a plugin registry; frames are destroyed before the registry unloads
// the libraries their techniques live in.
class PluginGpuTest : public GpuTest {
protected:
    void SetUp() override;
    void TearDown() override;
    // Renders `cfg` over `scene` into `frame` (replacing the last one), keeping the graph
    // images `debugImages` for frame->renderer.readImage.
    void render(const config::RenderConfig& cfg, scene::Scene scene, const std::vector<std::string>& debugImages = {});

    // Expects light 0's `v` to agree with rays from the light's centre within
    // `tolerance` away from edges (by `bandTexels`), with enough pixels surely shadowed
    // (> 150) and surely lit (> 2000) for that to mean something.
    void expectRayCastAgreement(const std::vector<float>& v, double bandTexels, float tolerance,
                                const std::string& label) const;

    // Expects light 0's `v` to be exactly 1 at every pixel that sees geometry, and more
    // than half of the pixels to see it: a receiver that nothing shadows.
    void expectExactlyLitWhereGeometry(const std::vector<float>& v, const std::string& label) const;

    std::unique_ptr<plugin::PluginRegistry> registry;
    std::unique_ptr<RenderedFrame> frame;
};

// Light `light`'s shadow set to `technique`, required, with `params` (name -> value) and
// the plugin's defaults for the rest.
void setShadow(config::LightConfig& light, const std::string& technique, const nlohmann::json& params);

// The fixture of one technique's tests: `Settings` (the parameters a test varies) are set
// on light 0 by `apply`, and renderWith returns the frame's checked visibility.
template <class Settings, void (*apply)(config::LightConfig&, const Settings&)>
class TechniqueTest : public PluginGpuTest {
protected:
    std::vector<float> renderWith(config::RenderConfig cfg, const Settings& s, scene::Scene scene)
    {
        apply(cfg.lights[0], s);
        render(cfg, std::move(scene));
        return frame->checkedVisibility();
    }
    // Over the scene `cfg` names.
    std::vector<float> renderWith(config::RenderConfig cfg, const Settings& s)
    {
        scene::Scene scene = config::buildScene(cfg.scene);
        return renderWith(std::move(cfg), s, std::move(scene));
    }
};

// Expects plugin `plugin` to refuse each (name, value) with a ConfigError that names the
// parameter, as it would when a config file's shadow settings set it.
void expectRefusalsNameTheParameter(const std::string& plugin,
                                    const std::vector<std::pair<std::string, nlohmann::json>>& values);

} // namespace penumbra::test
