#pragma once
// Preparing a run of a config, the one way every command and the viewer do it: the scene
// built from its source, the lights of a glTF file when the config says "lights":
// "scene", the --set overrides on the lights' techniques, and the command line's size,
// frames and culling. The order is the point: overrides name the techniques of lights
// that exist only once the scene is loaded.
#include "penumbra/config/Overrides.h"
#include "penumbra/config/RenderConfig.h"
#include "penumbra/scene/GltfLoader.h"
#include "penumbra/scene/Scene.h"

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace penumbra::config {

// What the command line changes in a config.
struct RunOptions {
    std::vector<ParamOverride> overrides;  // --set, in order (a later one wins)
    // A sweep variant takes only the overrides whose technique one of its lights uses:
    // the others are for other variants (the caller checks that each is used by one).
    // Otherwise an override that no light uses is an error.
    bool overridesOfUsedTechniquesOnly = false;
    std::optional<uint32_t> width;
    std::optional<uint32_t> height;
    std::optional<uint32_t> frames;
    std::optional<CullingMode> culling;
    std::optional<bool> keepUnchanged;  // the config's "keep_unchanged"
    // --allow-root: folders a glTF scene's URIs may name, added to every glTF part's
    // allowed roots (the config's scene.allowed_roots).
    std::vector<std::filesystem::path> allowedRoots;
};

// A config ready to render, and its scene.
struct PreparedRun {
    RenderConfig rest;    // resolved (lights, overrides, options): where every frame starts
    RenderConfig config;  // as the last poseAt left it (rest until then): what a frame draws
    scene::Scene scene;   // its nodes as the last poseAt left them

    // Poses config and scene at time `timeS` of the animation, starting from `rest`;
    // returns the instances that moved (Scene::updateTransforms) for FrameRenderer::update.
    std::vector<uint32_t> poseAt(float timeS);
    // Frame `frame` of the run shows time frame / fps.
    std::vector<uint32_t> poseAtFrame(uint32_t frame) { return poseAt(float(frame) / rest.animation.fps); }
};

// Throws ConfigError naming the file and JSON path (or the flag).
PreparedRun prepareRun(RenderConfig config, const RunOptions& options);

// A scene as its source builds it, with the lights its glTF files hold.
struct SceneBuild {
    scene::Scene scene;
    std::vector<scene::GltfLight> fileLights;
};

// prepareRun's config, over a scene built from config.scene (with the options' allowed
// roots): the lights of "lights": "scene" filled in, the tracks checked against the
// scene, the overrides and the command line's size, frames and culling applied.
RenderConfig resolveRun(RenderConfig config, const RunOptions& options, const SceneBuild& built);

// The scenes of one command's runs (bench's variants, compare's test and reference): a
// scene source is built once - its files loaded and repaired, its generators run - and
// every run of it takes that scene. Runs that pose the scene (animated ones, config::
// animated) need one of their own: prepareRun.
class SceneCache {
public:
    // The scene of `config`'s source, built at the first call for that source; adds the
    // options' allowed roots to `config`'s glTF parts, as prepareRun does. Throws
    // ConfigError as prepareRun does.
    const SceneBuild& build(RenderConfig& config, const RunOptions& options);
    size_t scenesBuilt() const { return scenes_.size(); }

    // What identifies a source: every part's kind, name, file (absolute), generator and
    // parameters, transform, allowed roots and animation.
    static std::string sourceKey(const SceneSource& source);

private:
    std::map<std::string, std::unique_ptr<SceneBuild>> scenes_;
};

// Whether frames of the config differ: it has tracks, or plays a glTF file's animation.
bool animated(const RenderConfig& config);
// The indices in scene.animations of the glTF animations the config's parts play, in
// part order (a part's "animation": a name among its own file's animations, else an
// index among them); empty for none. Throws ConfigError naming the part's
// /scene/.../animation and listing its file's animations when it has no such one.
std::vector<size_t> playedClips(const RenderConfig& config, const scene::Scene& scene);
// Poses `posed` (starting from `rest`) and the scene's nodes at `timeS`: first the glTF
// animations the config's parts play, then the config's own tracks (a node track overrides the
// file's channel of that node). Returns the instances that moved (Scene::updateTransforms).
std::vector<uint32_t> poseScene(const RenderConfig& rest, float timeS, RenderConfig& posed, scene::Scene& scene);
// The last key of the config's tracks and of the glTF animations it plays (0: at rest).
float animationDuration(const RenderConfig& config, const scene::Scene& scene);
PreparedRun prepareRun(const std::filesystem::path& file, const RunOptions& options);

// Builds the scene that the config's scene source describes: each part (a glTF file,
// loaded with the part's allowed roots, or a generator) under a root node of its own
// named as the part, whose transform places it; then checks that the animation's node
// tracks name nodes of that scene. With "lights": "scene" it also fills config.lights
// from the glTF parts' lights (every part's, in part order, placed by its transform),
// each named as the file names it (one without a name: `light<its index in the file>`; a
// name an earlier light took: `light<i>`, or `light<i>_2`, ... if that is taken too, i
// counting the lights of all parts), so that compare's files and bench's tables say
// "sun", not "light0". prepareRun does this first.
scene::Scene buildScene(RenderConfig& config);
// `fileLights` (optional) receives the glTF parts' KHR_lights_punctual lights with their
// names, placed by their parts' transforms (intensity times s² for a part scaled by s).
// Errors name the part ("/scene/parts/1: ...").
scene::Scene buildScene(const SceneSource& source, std::vector<scene::GltfLight>* fileLights = nullptr);

// One part's share of a scene that buildScene made (validate prints them).
struct PartSummary {
    size_t instances = 0;
    size_t triangles = 0;  // drawn: each instance's mesh's
    scene::Aabb bounds;    // world space, after the part's transform
};
std::vector<PartSummary> summarizeParts(const SceneSource& source, const scene::Scene& scene);

} // namespace penumbra::config
