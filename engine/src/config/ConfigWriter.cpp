#include "penumbra/config/ConfigWriter.h"

#include "penumbra/io/StagedFile.h"

#include <charconv>
#include <string>

using nlohmann::json;
namespace fs = std::filesystem;

namespace penumbra::config {
namespace {

// The shortest decimal that reads back to `value` as a float, as a JSON number: the
// config reader parses doubles and narrows them to float, so this round-trips exactly.
json number(float value)
{
    char text[32];
    const auto [end, ec] = std::to_chars(text, text + sizeof text, value);
    if (ec != std::errc()) return double(value);
    double shortest = 0.0;
    std::from_chars(text, end, shortest);
    return shortest;
}

json vec3(const glm::vec3& v) { return json::array({number(v.x), number(v.y), number(v.z)}); }

// A generator parameter is kept as the text the config gave (Generators.h parses it):
// a number or a boolean goes back as one, anything else as a string.
json generatorValue(const std::string& text)
{
    json parsed = json::parse(text, nullptr, false);
    if (!parsed.is_discarded() && (parsed.is_number() || parsed.is_boolean())) return parsed;
    return text;
}

// A path (a glTF file, an allowed root) as the reader resolves it: relative paths against
// the saved file's folder.
std::string scenePath(const fs::path& gltf, const fs::path& savedAs)
{
    std::error_code ec;
    const fs::path file = fs::weakly_canonical(fs::absolute(gltf, ec), ec);
    const fs::path folder = fs::weakly_canonical(fs::absolute(savedAs, ec).parent_path(), ec);
    const fs::path relative = file.lexically_relative(folder);
    // Across file-system roots (or when a folder cannot be resolved) the absolute path.
    if (ec || relative.empty() || file.root_path() != folder.root_path()) return file.generic_string();
    return relative.generic_string();
}

json dvec3(const glm::dvec3& v) { return json::array({v.x, v.y, v.z}); }

// The transform in full (the reader's defaults written out): doubles as read, so that
// they read back to the same value.
void writeTransform(const PartTransform& t, json& part)
{
    part["translation"] = dvec3(t.translation);
    if (t.rotationDeg) {
        part["rotation_deg"] = dvec3(*t.rotationDeg);
    } else {
        part["rotation"] = json::array({t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w});
    }
    const bool uniform = t.scale.x == t.scale.y && t.scale.y == t.scale.z;
    part["scale"] = uniform ? json(t.scale.x) : dvec3(t.scale);
}

json partJson(const ScenePart& part, const fs::path& savedAs)
{
    json out = json::object();
    out["name"] = part.name;
    if (part.kind == ScenePart::Kind::Gltf) {
        out["gltf"] = scenePath(part.gltf, savedAs);
        if (!part.animation.empty()) out["animation"] = part.animation;
        if (!part.allowedRoots.empty()) {
            json roots = json::array();
            for (const fs::path& root : part.allowedRoots) roots.push_back(scenePath(root, savedAs));
            out["allowed_roots"] = roots;
        }
    } else {
        out["generator"] = part.generator;
        json params = json::object();
        for (const auto& [name, text] : part.params) params[name] = generatorValue(text);
        if (!params.empty()) out["params"] = params;
    }
    writeTransform(part.transform, out);
    return out;
}

json cameraJson(const scene::Camera& camera)
{
    return {{"position", vec3(camera.position)},
            {"target", vec3(camera.target)},
            {"up", vec3(camera.up)},
            {"fov_y_deg", number(camera.fovYDeg)},
            {"near", number(camera.nearWorld)}};
}

json shadowJson(const ShadowSettings& shadow)
{
    json out = {{"technique", shadow.technique}};
    if (shadow.required) out["required"] = *shadow.required;
    for (const ShadowParam& param : shadow.params) out[param.name] = param.value;
    return out;
}

json lightJson(const LightConfig& lc)
{
    const scene::Light& l = lc.light;
    json out = {{"name", lc.name},
                {"type", scene::lightTypeName(l.type)},
                {"intensity", number(l.intensity)},
                {"color", vec3(l.color)}};
    if (l.type != scene::LightType::Directional) out["position"] = vec3(l.position);
    // The axis as the config gave it: a target is kept (an animation may move the light
    // and keep it aimed), a direction otherwise, and where the light was moved onto its
    // target (which gives no axis). Point lights have none.
    if (l.type != scene::LightType::Point) {
        if (lc.target && l.type != scene::LightType::Directional && *lc.target != l.position) {
            out["target"] = vec3(*lc.target);
        } else {
            out["direction"] = vec3(l.direction);
        }
    }
    switch (l.type) {
    case scene::LightType::Directional: out["angular_diameter_deg"] = number(l.angularDiameterDeg); break;
    case scene::LightType::Spot:
        out["outer_cone_deg"] = number(l.outerConeDeg);
        out["inner_cone_deg"] = number(l.innerConeDeg);
        break;
    case scene::LightType::Point: out["radius"] = number(l.radiusWorld); break;
    case scene::LightType::Rect:
        out["size"] = json::array({number(l.sizeWorld.x), number(l.sizeWorld.y)});
        out["tangent"] = vec3(l.tangent);
        break;
    case scene::LightType::Disk: out["radius"] = number(l.radiusWorld); break;
    }
    out["shadow"] = shadowJson(lc.shadow);
    return out;
}

const char* interpolationName(Interpolation interpolation)
{
    switch (interpolation) {
    case Interpolation::Step: return "step";
    case Interpolation::Smooth: return "smooth";
    case Interpolation::Linear: break;
    }
    return "linear";
}

json animationJson(const Animation& animation)
{
    json tracks = json::array();
    for (const AnimationTrack& track : animation.tracks) {
        json keys = json::array();
        for (const Keyframe& key : track.keys) {
            json value = json::array();
            for (float x : key.value) value.push_back(number(x));
            keys.push_back({{"t", number(key.timeS)}, {"value", key.value.size() == 1 ? value[0] : value}});
        }
        tracks.push_back({{"target", track.target}, {"interpolation", interpolationName(track.interpolation)}, {"keys", keys}});
    }
    return {{"fps", number(animation.fps)}, {"tracks", tracks}};
}

} // namespace

json sceneJson(const SceneSource& source, const fs::path& savedAs)
{
    if (!source.listed && source.parts.size() == 1) return partJson(source.parts[0], savedAs);
    json parts = json::array();
    for (const ScenePart& part : source.parts) parts.push_back(partJson(part, savedAs));
    return {{"parts", parts}};
}

json configJson(const RenderConfig& config, const fs::path& savedAs)
{
    json out = json::object();
    out["scene"] = sceneJson(config.scene, savedAs);
    out["camera"] = cameraJson(config.camera);
    if (config.lights.empty() && config.lightsFromScene) {
        out["lights"] = "scene";
    } else {
        // Lights taken from a glTF file are written out: the saved file shows what the
        // viewer showed, with the techniques and parameters chosen there.
        json lights = json::array();
        for (const LightConfig& light : config.lights) lights.push_back(lightJson(light));
        out["lights"] = lights;
    }
    out["culling"] = cullingModeName(config.culling);
    out["shadow_focus"] = config.shadowFocus;
    out["light_culling"] = config.lightCulling;
    out["keep_unchanged"] = config.keepUnchanged;
    out["max_shadowed_lights"] = config.maxShadowedLights;
    out["draw_batching"] = config.batchDraws ? "batched" : "per-instance";
    out["output"] = {{"width", config.width}, {"height", config.height}};
    out["frames"] = config.frames;
    // Without tracks, fps is the frame rate of the glTF animation the scene plays.
    if (!config.animation.empty() || config.scene.playsClip()) out["animation"] = animationJson(config.animation);
    if (!config.notes.empty()) out["notes"] = config.notes;
    return out;
}

void saveConfig(const RenderConfig& config, const fs::path& file)
{
    io::writeTextFile(file, configJson(config, file).dump(2) + "\n");
}

} // namespace penumbra::config
