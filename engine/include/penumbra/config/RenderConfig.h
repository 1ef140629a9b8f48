#pragma once
// What one run of a config renders (config/Config.h lists the rest of the config API):
// scene source (a glTF file or a generator with parameters), camera, lights with their
// shadow technique and its parameters, culling mode, output size, frame count and
// animation tracks, read from a ConfigDocument and validated. Every error names the file
// (the one the value came from, through includes), the JSON path and what is expected:
//   "scene.json: /lights/0/outer_cone_deg: must be in (0, 89], got 120".
#include "penumbra/config/Animation.h"
#include "penumbra/config/Document.h"
#include "penumbra/scene/Generators.h"
#include "penumbra/scene/Scene.h"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
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
// The technique name of an unshadowed light: no plugin, no passes, no visibility image;
// shading takes V = 1 (the baseline a trade-off table compares techniques with).
inline constexpr std::string_view kNoShadowTechnique = "none";

// Ends the message of a technique that cannot be loaded when the light does not say
// "required": what to write to go on without it.
inline constexpr std::string_view kOptionalTechniqueHint =
    " (set \"required\": false in the light's \"shadow\" to render it unshadowed instead)";

struct ShadowSettings {
    std::string technique = "hard";  // a plugin's name, or kNoShadowTechnique
    // Where the config names the technique ("a.json: /lights/0/shadow/technique"); empty
    // when no config did (the default, a program's own settings).
    std::string techniqueWhere;
    // "required": true: a technique that fails to load or to register stops the run
    // (exit != 0). Unset: a technique that cannot be loaded (no plugin has the name, a
    // misspelling; a damaged plugin) stops the run, one that loads but fails to register
    // (it refuses the light) is dropped with a warning. false: every failure is a warning
    // and the light renders unshadowed (V = 1).
    std::optional<bool> required;
    std::vector<ShadowParam> params;

    bool unshadowed() const { return technique == kNoShadowTechnique; }
    bool loadFailureStopsTheRun() const { return required.value_or(true); }
    bool registrationFailureStopsTheRun() const { return required.value_or(false); }

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
    // Kind::Gltf: folders besides the file's own whose files its URIs may name (resolved
    // against the config's folder; the command line's --allow-root adds to them).
    std::vector<std::filesystem::path> allowedRoots;
    // Kind::Gltf: the file's animation that plays (its name, or its index as text), empty
    // for none: the scene at rest. Posed by poseScene (config/Run.h) with the config's own
    // tracks.
    std::string animation;
};

struct RenderConfig {
    std::filesystem::path file;  // where it was read from, for messages
    SceneSource scene;
    scene::Camera camera;
    std::vector<LightConfig> lights;
    // "lights": "scene": the lights come from the glTF file (KHR_lights_punctual), with
    // default shadow settings; resolved by buildScene (config/Run.h).
    bool lightsFromScene = false;
    CullingMode culling = CullingMode::None;
    // Fit directional and spot lights' shadow maps to what the camera sees (the visibility
    // service's "focusing", engine/src/visibility/); needs culling receiver-mask or light-occlusion.
    bool shadowFocus = false;
    // "draw_batching": "batched" (instanced, indirect multi-draws: render::SceneGpu) or
    // "per-instance" (one draw call per instance: the reference batching is checked and
    // measured against).
    bool batchDraws = true;
    uint32_t width = 1280;
    uint32_t height = 720;
    uint32_t frames = 1;
    Animation animation;
    // "notes": Markdown paragraphs about the run that its figures cannot show (a limit of a
    // technique the sweep measures, say); `penumbra bench --summary` prints them.
    std::vector<std::string> notes;
};

// Validates a document (its "sweep" is ignored: the unswept values are the base run).
RenderConfig parseConfig(const ConfigDocument& document);
RenderConfig parseConfig(const nlohmann::json& json, const std::filesystem::path& file);

// Reads, merges and validates a config file. Throws ConfigError naming file and path.
RenderConfig loadConfig(const std::filesystem::path& file);

// The most lights one frame shades: the shading pass binds one visibility image each
// and reads them with constant indices (shaders/engine/shading.comp).
inline constexpr uint32_t kMaxLights = 8;

} // namespace penumbra::config
