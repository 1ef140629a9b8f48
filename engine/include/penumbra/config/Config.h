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

// One technique parameter as the config (or --set) gives it; the plugin's reflection
// (plugin/Params.h) checks it when the technique is created.
struct ShadowParam {
    std::string name;
    nlohmann::json value;
    std::string where;  // "scene.json: /lights/0/shadow/pcf_kernel" or "--set hard.pcf_kernel"
};

// "shadow": {"technique": "hard", "required": true, "pcf_kernel": 5, ...}: the technique
// plugin, whether a failure to load it ends the run, and every other key as a parameter.
struct ShadowSettings {
    std::string technique = "hard";
    // A required technique that fails to load or register stops the run (exit != 0);
    // otherwise the light is rendered unshadowed (V = 1) with a warning.
    bool required = false;
    std::vector<ShadowParam> params;

    // The parameter's value as given, or null when the config leaves it at the default.
    const nlohmann::json* param(std::string_view name) const;
    // Sets (or replaces) a parameter.
    void setParam(std::string name, nlohmann::json value, std::string where);
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
// "none", "frustum", "light-occlusion", "receiver-mask"; throws ConfigError otherwise.
CullingMode parseCullingMode(std::string_view name);

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
    // Fit directional and spot lights' shadow maps to what the camera sees (the visibility
    // service's "focusing", engine/src/visibility/); needs culling receiver-mask or light-occlusion.
    bool shadowFocus = false;
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
// 1024]}, ...] gives the Cartesian product of the listed values (the first entry varies
// slowest); each variant is the document with those paths set. A value replaces what is
// at its path whole, so sweeping an object ("/lights/0/shadow": [{"technique": "hard"},
// {"technique": "pcss", "light_size": 1}]) changes a technique together with its
// parameters, and "/scene" changes the scene. Entries are applied in order: a later one
// may set a value inside an object an earlier one swept. "paths": [...] sets several
// pointers together, each value then an array with one entry per path (a scene with the
// camera that frames it). "labels": [...] names the values for tables and plots. A config
// without a sweep has one variant, itself.
struct SweepChoice {
    std::vector<std::string> paths;  // the entry's JSON pointers
    size_t value = 0;                // index into the entry's "values"
    std::string label;               // its "labels" entry, or the value as JSON
    bool labelled = false;           // the label is the entry's own ("labels")
};
struct SweepVariant {
    std::string label;  // "/lights/0/shadow/resolution=512, ..."; empty without a sweep
    std::vector<SweepChoice> choices;  // one per sweep entry, in order; empty without a sweep
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
