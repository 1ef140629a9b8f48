#include "penumbra/config/Run.h"

#include "penumbra/config/Animation.h"
#include "penumbra/core/Error.h"
#include "penumbra/scene/GltfLoader.h"

#include <fmt/format.h>

#include <set>

namespace penumbra::config {

scene::Scene buildScene(const SceneSource& source, std::vector<scene::GltfLight>* fileLights)
{
    scene::Scene scene;
    if (source.kind == SceneSource::Kind::Gltf) {
        scene::GltfLoadReport report;
        scene = scene::loadGltf(source.gltf, report);
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
    std::set<std::string> nodeNames;
    for (uint32_t n = 0; n < scene.graph.size(); ++n) nodeNames.insert(scene.graph.node(n).name);
    for (size_t i = 0; i < config.animation.tracks.size(); ++i) {
        const std::string& target = config.animation.tracks[i].target;
        if (target.rfind("node:", 0) != 0) continue;
        const std::string name = target.substr(5, target.rfind('/') - 5);
        if (!nodeNames.count(name)) {
            throw ConfigError(fmt::format("{}: /animation/tracks/{}/target: the scene has no node named \"{}\"",
                                          config.file.string(), i, name));
        }
    }
    return scene;
}

PreparedRun prepareRun(RenderConfig config, const RunOptions& options)
{
    PreparedRun run;
    run.scene = buildScene(config);
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

std::vector<uint32_t> PreparedRun::poseAt(float timeS)
{
    config = rest;
    applyAnimation(rest.animation, timeS, config, scene);
    return scene.updateTransforms();
}

} // namespace penumbra::config
