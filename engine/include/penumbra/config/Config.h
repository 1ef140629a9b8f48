#pragma once
// The scene config a user edits and a script writes (JSON). This is the foundation's
// minimal form: scene generator, camera, lights with their shadow settings, output
// size and frame count. Every error names the file, the JSON path and what is expected:
//   "scene.json: /lights/0/outer_cone_deg: must be in (0, 89], got 120".
#include "penumbra/scene/Generators.h"

#include <nlohmann/json_fwd.hpp>

#include <filesystem>
#include <string>
#include <vector>

namespace penumbra::config {

struct ShadowSettings {
    std::string technique = "hard";
    uint32_t resolution = 2048;  // shadow-map texels per side
    // Depth bias in Vulkan's units: constant in multiples of the depth format's minimum
    // resolvable difference at the primitive's depth, slope as a factor of the
    // primitive's maximum depth slope, clamp as a depth difference (0: no clamp). The
    // engine applies them away from the light whatever the depth convention (reversed-Z).
    // Slope 2: a receiver is up to half a texel from the centre of the texel it samples
    // in each axis (one max slope), and near texel borders the sampler's fixed-point
    // coordinates may pick the neighbour (one more); 1.5 left isolated acne pixels on
    // surfaces at ~78 degrees from the light in tests/test_render.cpp.
    float depthBiasConstant = 4.0f;
    float depthBiasSlope = 2.0f;
    float depthBiasClamp = 0.0f;
};

struct LightConfig {
    scene::Light light;
    ShadowSettings shadow;
};

struct SceneSource {
    std::string generator = "box-grid";
    scene::BoxGridParams boxGrid;
};

struct RenderConfig {
    std::filesystem::path file;  // where it was read from, for messages
    SceneSource scene;
    scene::Camera camera;
    std::vector<LightConfig> lights;
    uint32_t width = 1280;
    uint32_t height = 720;
    uint32_t frames = 1;
};

// Reads and validates a config file. Throws ConfigError naming file and JSON path.
RenderConfig loadConfig(const std::filesystem::path& file);

// Validates an already-parsed document; `file` is only used in messages.
RenderConfig parseConfig(const nlohmann::json& document, const std::filesystem::path& file);

// Builds the scene that the config's scene source describes.
scene::Scene buildScene(const SceneSource& source);

// The most lights one frame shades: the shading pass binds one visibility image each
// and reads them with constant indices (shaders/engine/shading.comp).
inline constexpr uint32_t kMaxLights = 8;

} // namespace penumbra::config
