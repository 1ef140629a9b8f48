#pragma once
// The scene config a user edits and a script writes (JSON): scene source (a glTF file or
// a generator with parameters), camera, lights with their shadow technique and its
// parameters, culling mode, output size, frame count, animation tracks that script a
// whole run, `include` of other configs with overrides, and parameter sweeps.
// config/schema/penumbra-config.schema.json describes the same format for editors.
// Every error names the file (the one the value came from, through includes), the JSON
// path and what is expected:
//   "scene.json: /lights/0/outer_cone_deg: must be in (0, 89], got 120".
#include "penumbra/config/Animation.h"
#include "penumbra/scene/Scene.h"
#include "penumbra/scene/Generators.h"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace penumbra::config {

struct ShadowSettings {
    std::string technique = "hard";
    uint32_t resolution = 2048;  // shadow-map texels per side (per cube face for point lights)
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
    std::string name;                 // for messages and animation targets; "light<i>" by default
    scene::Light light;
    std::optional<glm::vec3> target;  // when given, direction = normalize(target - position)
    ShadowSettings shadow;
};

// Which casters the shadow passes draw (the visibility-culling issue implements them).
enum class CullingMode { None, Frustum, LightOcclusion, ReceiverMask };
const char* cullingModeName(CullingMode mode);

struct SceneSource {
    enum class Kind { Generator, Gltf };
    Kind kind = Kind::Generator;
    std::filesystem::path gltf;       // Kind::Gltf, resolved against the config's folder
    std::string generator = "box-grid";  // one of scene::generatorNames()
    // The generator's parameters that the config sets, by name, values as text (the
    // generator parses and validates them: scene/Generators.h).
    std::vector<std::pair<std::string, std::string>> params;
    float scale = 1.0f;               // every length times this (1e-3 ... 1e5 are tested)
};

struct RenderConfig {
    std::filesystem::path file;  // where it was read from, for messages
    SceneSource scene;
    scene::Camera camera;
    std::vector<LightConfig> lights;
    // "lights": "scene": the lights come from the glTF file (KHR_lights_punctual), with
    // default shadow settings; resolved by buildScene.
    bool lightsFromScene = false;
    CullingMode culling = CullingMode::None;
    uint32_t width = 1280;
    uint32_t height = 720;
    uint32_t frames = 1;
    Animation animation;
};

// A config file with its includes resolved: the merged document, and for each JSON
// path the file its value came from (for messages).
struct ConfigDocument {
    std::filesystem::path file;
    nlohmann::json json;
    std::map<std::string, std::string> origin;  // JSON pointer -> file name
    std::string fileFor(const std::string& pointer) const;
};

// Reads `file` and its includes: `"include": "base.json"` or a list, paths relative to
// the including file, merged in order with RFC 7386 merge-patch semantics (objects merge
// key by key, everything else - arrays too - is replaced, null removes a key), then the
// including file on top. Include cycles and missing files are errors naming the chain.
ConfigDocument loadDocument(const std::filesystem::path& file);

// Validates a document (its "sweep" is ignored: the unswept values are the base run).
RenderConfig parseConfig(const ConfigDocument& document);
RenderConfig parseConfig(const nlohmann::json& json, const std::filesystem::path& file);

// Reads, merges and validates a config file. Throws ConfigError naming file and path.
RenderConfig loadConfig(const std::filesystem::path& file);

// A parameter sweep: "sweep": [{"path": "/lights/0/shadow/resolution", "values": [512,
// 1024]}, ...] gives the Cartesian product of the listed values; each variant is the
// document with those paths set. A config without a sweep has one variant, itself.
struct SweepVariant {
    std::string label;  // "/lights/0/shadow/resolution=512, ..."; empty without a sweep
    RenderConfig config;
};
std::vector<SweepVariant> expandSweep(const ConfigDocument& document);

// Builds the scene that the config's scene source describes (at its scale), and checks
// that the animation's node tracks name nodes of that scene. With "lights": "scene" it
// also fills config.lights from the glTF file's lights.
scene::Scene buildScene(RenderConfig& config);
// `fileLights` (optional) receives a glTF file's KHR_lights_punctual lights, placed and
// scaled with the scene.
scene::Scene buildScene(const SceneSource& source, std::vector<scene::Light>* fileLights = nullptr);

// Moves camera, lights and scene nodes to time `timeS` of the config's animation.
// `config` holds the animated values afterwards; nodes are set in `scene`'s graph (call
// scene.updateTransforms() after).
void applyAnimation(const Animation& animation, float timeS, RenderConfig& config, scene::Scene& scene);

// The most lights one frame shades: the shading pass binds one visibility image each
// and reads them with constant indices (shaders/engine/shading.comp).
inline constexpr uint32_t kMaxLights = 8;

} // namespace penumbra::config
