#pragma once
// What one run of a config renders (config/Config.h lists the rest of the config API):
// scene source (glTF files and generators, each placed by a transform), camera, lights with their
// shadow technique and its parameters, culling mode, output size, frame count and
// animation tracks, read from a ConfigDocument and validated. Every error names the file
// (the one the value came from, through includes), the JSON path and what is expected:
//   "scene.json: /lights/0/outer_cone_deg: must be in (0, 89], got 120".
#include "penumbra/config/Animation.h"
#include "penumbra/config/Document.h"
#include "penumbra/scene/Generators.h"
#include "penumbra/scene/Scene.h"

#include <glm/gtc/quaternion.hpp>
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

// Where a part of the scene sits: x_world = T · R · S · x_part, kept in double as the
// config gives it and rounded to float once, as the part's root node's transform.
struct PartTransform {
    glm::dvec3 translation{0.0};
    glm::dquat rotation{1.0, 0.0, 0.0, 0.0};  // unit
    // The rotation as Euler angles in degrees when the config gave "rotation_deg" (the
    // convention of a node track's rotation_deg: R = Rx · Ry · Rz), for Save to write
    // back as it was read; empty when it gave a quaternion "rotation" (or none).
    std::optional<glm::dvec3> rotationDeg;
    glm::dvec3 scale{1.0};  // every component in (0, kMaxPartScale]

    glm::dmat4 matrix() const;  // T · R · S
};

// The largest scale factor of a part (each component), as for the single "scale" before.
inline constexpr double kMaxPartScale = 1e9;

// One glTF file or one generator, placed by its transform. Every part becomes one root
// node of the scene (named `name`) with the part's own nodes below it.
struct ScenePart {
    enum class Kind { Generator, Gltf };
    Kind kind = Kind::Generator;
    // The part's root node: animation tracks move the whole part as "node:<name>/...".
    std::string name = "part0";
    // Where the config gave the part: "/scene" or "/scene/parts/<i>", for messages.
    std::string pointer = "/scene";
    std::filesystem::path gltf;          // Kind::Gltf, resolved against the config's folder
    std::string generator = "box-grid";  // one of scene::generatorNames()
    // The generator's parameters that the config sets, by name, values as text (the
    // generator parses and validates them: scene/Generators.h).
    std::vector<std::pair<std::string, std::string>> params;
    PartTransform transform;
    // Kind::Gltf: folders besides the file's own whose files its URIs may name (resolved
    // against the config's folder; the command line's --allow-root adds to them).
    std::vector<std::filesystem::path> allowedRoots;
    // Kind::Gltf: the file's animation that plays (its name, or its index among the file's
    // animations as text), empty for none: the part at rest. Posed by poseScene
    // (config/Run.h) with the config's own tracks.
    std::string animation;

    // "box-grid" or the glTF file's name, for messages and tables.
    std::string sourceName() const;
};

// The most parts a scene may have: each is a file to load or a generator to run.
inline constexpr size_t kMaxSceneParts = 64;

// "scene": one part's keys ({"gltf": ...} or {"generator": ...}, with a transform), or
// {"parts": [part, ...]} for several.
struct SceneSource {
    std::vector<ScenePart> parts{ScenePart{}};  // 1 to kMaxSceneParts
    // The config gave "parts" (Save writes the form it read).
    bool listed = false;

    bool hasGltf() const;
    // Whether a part plays one of its glTF file's animations.
    bool playsClip() const;
    // "box-grid", or "model.glb + box-grid" for several parts.
    std::string describe() const;
};

// The most lights one frame shades: the shading pass binds one visibility image each
// and reads them with constant indices (shaders/engine/shading.comp).
inline constexpr uint32_t kMaxLights = 8;

struct RenderConfig {
    std::filesystem::path file;  // where it was read from, for messages
    SceneSource scene;
    scene::Camera camera;
    std::vector<LightConfig> lights;
    // "lights": "scene": the lights come from the glTF parts (KHR_lights_punctual; every
    // part's, placed by its transform), with default shadow settings; resolved by
    // buildScene (config/Run.h).
    bool lightsFromScene = false;
    CullingMode culling = CullingMode::None;
    // Fit directional and spot lights' shadow maps to what the camera sees (the visibility
    // service's "focusing", engine/src/visibility/); needs culling receiver-mask or light-occlusion.
    bool shadowFocus = false;
    // "light_culling": a light that reaches no receiver the camera sees gets no passes and
    // no light (frame/LightInfluence.h); false draws every light.
    bool lightCulling = true;
    // "keep_unchanged": a pass whose light, casters, camera and inputs did not change
    // since it last ran keeps its results instead of running again (a shadow map under a
    // still light, a still frame's every pass; graph::PassBuilder::dependsOn); false runs
    // every pass every frame. The images are the same either way.
    bool keepUnchanged = true;
    // "max_shadowed_lights": shadows on at most this many lights, the ones that contribute
    // most to the image; the others are lit unshadowed (1 to kMaxLights).
    uint32_t maxShadowedLights = kMaxLights;
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


} // namespace penumbra::config
