#include "penumbra/config/Run.h"

#include "penumbra/config/Animation.h"
#include "penumbra/core/Error.h"
#include "penumbra/core/ShortText.h"
#include "penumbra/scene/GltfLoader.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <set>

namespace penumbra::config {

namespace {

SceneBuild buildSceneOf(const RenderConfig& config)
{
    SceneBuild build;
    try {
        build.scene = buildScene(config.scene, &build.fileLights);
    } catch (const ConfigError&) {
        throw;
    } catch (const Error& e) {
        // The error names the part (/scene/parts/1) and what in it; add the config file.
        throw ConfigError(fmt::format("{}: {}", displayPath(config.file), e.what()));
    }
    return build;
}

// What buildScene(RenderConfig&) does once the scene is built: the lights of "lights":
// "scene", the played clips and the node tracks checked against the scene.
void completeFromScene(RenderConfig& config, const scene::Scene& scene, const std::vector<scene::GltfLight>& fileLights)
{
    if (config.lightsFromScene) {
        if (fileLights.empty() || fileLights.size() > kMaxLights) {
            throw ConfigError(fmt::format("{}: /lights: \"scene\" needs 1 to {} KHR_lights_punctual lights in the scene's "
                                          "glTF files ({}), found {}",
                                          displayPath(config.file), kMaxLights, core::shortText(config.scene.describe()),
                                          fileLights.size()));
        }
        config.lights.clear();
        std::set<std::string> names;
        for (size_t i = 0; i < fileLights.size(); ++i) {
            LightConfig lc;
            // The loader names an unnamed light light<its index in the file>; a name an
            // earlier light took gets light<i>, then light<i>_2, ..., until it is free.
            lc.name = fileLights[i].name;
            for (int n = 1; lc.name.empty() || names.count(lc.name); ++n)
                lc.name = n == 1 ? fmt::format("light{}", i) : fmt::format("light{}_{}", i, n);
            names.insert(lc.name);
            lc.light = fileLights[i].light;
            config.lights.push_back(lc);
        }
    }
    playedClips(config, scene);  // the animations its parts play exist
    std::set<std::string> nodeNames;
    for (uint32_t n = 0; n < scene.graph.size(); ++n) nodeNames.insert(scene.graph.node(n).name);
    for (size_t i = 0; i < config.animation.tracks.size(); ++i) {
        const std::string& target = config.animation.tracks[i].target;
        if (target.rfind("node:", 0) != 0) continue;
        const std::string name = target.substr(5, target.rfind('/') - 5);
        if (!nodeNames.count(name)) {
            throw ConfigError(fmt::format("{}: /animation/tracks/{}/target: the scene has no node named \"{}\"",
                                          displayPath(config.file), i, core::shortText(name)));
        }
    }
}

void addAllowedRoots(RenderConfig& config, const RunOptions& options)
{
    for (ScenePart& part : config.scene.parts) {
        if (part.kind == ScenePart::Kind::Gltf) {
            part.allowedRoots.insert(part.allowedRoots.end(), options.allowedRoots.begin(), options.allowedRoots.end());
        }
    }
}

} // namespace

scene::Scene buildScene(RenderConfig& config)
{
    SceneBuild build = buildSceneOf(config);
    completeFromScene(config, build.scene, build.fileLights);
    return std::move(build.scene);
}

RenderConfig resolveRun(RenderConfig config, const RunOptions& options, const SceneBuild& built)
{
    completeFromScene(config, built.scene, built.fileLights);
    applyParamOverrides(config, options.overridesOfUsedTechniquesOnly ? overridesUsedBy(options.overrides, config)
                                                                       : options.overrides);
    if (options.width) config.width = *options.width;
    if (options.height) config.height = *options.height;
    if (options.frames) config.frames = *options.frames;
    if (options.culling) config.culling = *options.culling;
    if (options.keepUnchanged) config.keepUnchanged = *options.keepUnchanged;
    return config;
}

PreparedRun prepareRun(RenderConfig config, const RunOptions& options)
{
    addAllowedRoots(config, options);
    SceneBuild built = buildSceneOf(config);
    PreparedRun run;
    run.rest = resolveRun(std::move(config), options, built);
    run.config = run.rest;
    run.scene = std::move(built.scene);
    return run;
}

const SceneBuild& SceneCache::build(RenderConfig& config, const RunOptions& options)
{
    addAllowedRoots(config, options);
    std::string key = sourceKey(config.scene);
    auto found = scenes_.find(key);
    if (found == scenes_.end()) {
        auto built = std::make_unique<SceneBuild>(buildSceneOf(config));
        found = scenes_.emplace(std::move(key), std::move(built)).first;
    }
    return *found->second;
}

std::string SceneCache::sourceKey(const SceneSource& source)
{
    // Every field of every part that buildScene reads; doubles printed exactly (fmt's
    // shortest round trip), paths absolute.
    std::string key;
    for (const ScenePart& part : source.parts) {
        const PartTransform& t = part.transform;
        key += fmt::format("{}|{}|{}|{}|", int(part.kind), part.name,
                           part.kind == ScenePart::Kind::Gltf ? std::filesystem::absolute(part.gltf).string() : "",
                           part.kind == ScenePart::Kind::Generator ? part.generator : "");
        for (const auto& [name, value] : part.params) key += fmt::format("{}={};", name, value);
        key += fmt::format("|{},{},{}|{},{},{},{}|{},{},{}|", t.translation.x, t.translation.y, t.translation.z,
                           t.rotation.w, t.rotation.x, t.rotation.y, t.rotation.z, t.scale.x, t.scale.y, t.scale.z);
        for (const std::filesystem::path& root : part.allowedRoots) key += std::filesystem::absolute(root).string() + ";";
        key += "|" + part.animation + "\n";
    }
    return key;
}

PreparedRun prepareRun(const std::filesystem::path& file, const RunOptions& options)
{
    return prepareRun(loadConfig(file), options);
}

bool animated(const RenderConfig& config) { return !config.animation.empty() || config.scene.playsClip(); }

std::vector<uint32_t> poseScene(const RenderConfig& rest, float timeS, RenderConfig& posed, scene::Scene& scene)
{
    posed = rest;
    for (const size_t clip : playedClips(rest, scene)) scene::applyNodeAnimation(scene.animations[clip], timeS, scene.graph);
    applyAnimation(rest.animation, timeS, posed, scene);
    return scene.updateTransforms();
}

float animationDuration(const RenderConfig& config, const scene::Scene& scene)
{
    float end = 0.0f;
    for (const AnimationTrack& track : config.animation.tracks) {
        if (!track.keys.empty()) end = std::max(end, track.keys.back().timeS);
    }
    for (const size_t clip : playedClips(config, scene)) end = std::max(end, scene.animations[clip].duration());
    return end;
}

std::vector<uint32_t> PreparedRun::poseAt(float timeS) { return poseScene(rest, timeS, config, scene); }

} // namespace penumbra::config
