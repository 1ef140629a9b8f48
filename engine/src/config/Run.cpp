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

scene::Scene buildScene(const SceneSource& source, std::vector<scene::GltfLight>* fileLights)
{
    scene::Scene scene;
    if (source.kind == SceneSource::Kind::Gltf) {
        scene::GltfLoadReport report;
        scene::GltfLoadOptions options;
        options.allowedRoots = source.allowedRoots;
        scene = scene::loadGltf(source.gltf, report, options);
        if (scene.instances.empty()) {
            throw ConfigError(fmt::format("{}: the glTF file has no triangles to render", source.gltf.string()));
        }
        for (const scene::GltfLight& l : report.lights) {
            if (!fileLights) break;
            scene::GltfLight light = l;
            // Scaling the scene about the origin moves its lights with it; radiant
            // intensity times s² keeps the irradiance it gives the scaled scene.
            light.light.position *= source.scale;
            if (light.light.type != scene::LightType::Directional) light.light.intensity *= source.scale * source.scale;
            fileLights->push_back(light);
        }
    } else {
        scene = scene::generateScene(source.generator, source.params);
    }
    if (source.scale != 1.0f) scene::scaleScene(scene, source.scale);
    return scene;
}

scene::Scene buildScene(RenderConfig& config)
{
    scene::Scene scene;
    std::vector<scene::GltfLight> fileLights;
    try {
        scene = buildScene(config.scene, &fileLights);
    } catch (const ConfigError&) {
        throw;
    } catch (const Error& e) {
        // A generator's parameter error names the parameter; add where it was set.
        throw ConfigError(fmt::format("{}: /scene: {}", config.file.string(), e.what()));
    }
    if (config.lightsFromScene) {
        if (fileLights.empty() || fileLights.size() > kMaxLights) {
            throw ConfigError(fmt::format("{}: /lights: \"scene\" needs 1 to {} KHR_lights_punctual lights in {}, found {}",
                                          config.file.string(), kMaxLights, config.scene.gltf.string(), fileLights.size()));
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
    sceneAnimationIndex(config, scene);  // the animation it plays exists
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
    return scene;
}

PreparedRun prepareRun(RenderConfig config, const RunOptions& options)
{
    PreparedRun run;
    run.scene = buildScene(config);
    config.scene.allowedRoots.insert(config.scene.allowedRoots.end(), options.allowedRoots.begin(), options.allowedRoots.end());
    applyParamOverrides(config, options.overridesOfUsedTechniquesOnly ? overridesUsedBy(options.overrides, config)
                                                                       : options.overrides);
    if (options.width) config.width = *options.width;
    if (options.height) config.height = *options.height;
    if (options.frames) config.frames = *options.frames;
    if (options.culling) config.culling = *options.culling;
    run.rest = config;
    run.config = std::move(config);
    return run;
}

PreparedRun prepareRun(const std::filesystem::path& file, const RunOptions& options)
{
    return prepareRun(loadConfig(file), options);
}

bool animated(const RenderConfig& config) { return !config.animation.empty() || !config.scene.animation.empty(); }

int sceneAnimationIndex(const RenderConfig& config, const scene::Scene& scene)
{
    const std::string& wanted = config.scene.animation;
    if (wanted.empty()) return -1;
    for (size_t i = 0; i < scene.animations.size(); ++i) {
        if (scene.animations[i].name == wanted) return int(i);
    }
    if (std::all_of(wanted.begin(), wanted.end(), [](char c) { return c >= '0' && c <= '9'; }) && wanted.size() < 9) {
        const size_t index = std::stoul(wanted);
        if (index < scene.animations.size()) return int(index);
    }
    std::vector<std::string> names;
    for (const scene::NodeAnimation& a : scene.animations) names.push_back("\"" + a.name + "\"");
    throw ConfigError(fmt::format("{}: /scene/animation: {} has no animation \"{}\"; {}", config.file.string(),
                                  displayPath(config.scene.gltf), core::shortText(wanted),
                                  names.empty() ? std::string("it has none that can play")
                                                : fmt::format("its animations: {} (or their index)", fmt::join(names, ", "))));
}

std::vector<uint32_t> poseScene(const RenderConfig& rest, float timeS, RenderConfig& posed, scene::Scene& scene)
{
    posed = rest;
    if (const int clip = sceneAnimationIndex(rest, scene); clip >= 0) {
        scene::applyNodeAnimation(scene.animations[size_t(clip)], timeS, scene.graph);
    }
    applyAnimation(rest.animation, timeS, posed, scene);
    return scene.updateTransforms();
}

float animationDuration(const RenderConfig& config, const scene::Scene& scene)
{
    float end = 0.0f;
    for (const AnimationTrack& track : config.animation.tracks) {
        if (!track.keys.empty()) end = std::max(end, track.keys.back().timeS);
    }
    if (const int clip = sceneAnimationIndex(config, scene); clip >= 0) end = std::max(end, scene.animations[size_t(clip)].duration());
    return end;
}

std::vector<uint32_t> PreparedRun::poseAt(float timeS) { return poseScene(rest, timeS, config, scene); }

} // namespace penumbra::config
