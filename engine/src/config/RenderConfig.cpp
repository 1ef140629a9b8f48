#include "penumbra/config/RenderConfig.h"

#include "config/AnimationReader.h"
#include "config/JsonReader.h"
#include "config/SceneReader.h"
#include "core/Text.h"
#include "penumbra/core/Error.h"
#include "penumbra/core/ShortText.h"

#include <fmt/format.h>

#include <algorithm>
#include <set>

using nlohmann::json;
namespace fs = std::filesystem;

namespace penumbra::config {
namespace {

scene::Camera readCamera(ObjectReader& parent)
{
    scene::Camera camera;
    ObjectReader r(parent.require("camera"), parent.locator(), "/camera");
    camera.position = r.vec3("position", camera.position, true);
    camera.target = r.vec3("target", camera.target, true);
    camera.up = r.vec3("up", camera.up);
    camera.fovYDeg = float(r.number("fov_y_deg", camera.fovYDeg, 0.0, 179.0, true));
    camera.nearWorld = float(r.number("near", camera.nearWorld, 0.0, 1e9, true));
    r.finish();
    const glm::vec3 forward = camera.target - camera.position;
    if (!(glm::length(forward) > 0.0f)) r.fail("/camera/target", "must differ from /camera/position");
    if (!(glm::length(camera.up) > 0.0f) ||
        glm::length(glm::cross(glm::normalize(forward), glm::normalize(camera.up))) < 1e-4f) {
        r.fail("/camera/up", "must be non-zero and not parallel to the view direction");
    }
    return camera;
}

ShadowSettings readShadow(ObjectReader& light)
{
    ShadowSettings s;
    const json* v = light.find("shadow");
    if (!v) return s;
    ObjectReader r(*v, light.locator(), light.path("shadow"));
    s.technique = r.string("technique", s.technique);
    if (r.find("technique")) s.techniqueWhere = light.locator().where(r.path("technique"));
    // The plugin's file, penumbra-<name>.so, must fit a file system's 255-byte names.
    constexpr size_t kMaxPluginNameChars = 255 - std::string_view("penumbra-.so").size();
    const bool nameOk = s.technique.size() <= kMaxPluginNameChars &&
                        std::all_of(s.technique.begin(), s.technique.end(), [](char c) {
                            return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
                        });
    if (!nameOk) {
        r.fail(r.path("technique"), fmt::format("must be a plugin name ([a-z0-9_-]+, at most {} characters), got {}",
                                                kMaxPluginNameChars, core::shortJson(s.technique)));
    }
    if (const json* required = r.find("required")) {
        if (!required->is_boolean()) r.fail(r.path("required"), fmt::format("must be true or false, got {}", core::shortJson(*required)));
        s.required = required->get<bool>();
    }
    // Every other key is a parameter of the technique: its plugin's reflection checks
    // name, type and range when the technique is created.
    for (auto it = v->begin(); it != v->end(); ++it) {
        if (it.key() == "technique" || it.key() == "required") continue;
        // A key an edit or two from these is their typo, not a parameter (no plugin names
        // one so): said here, rather than as a parameter the plugin does not have.
        if (const std::string best = core::closestMatch(it.key(), {"technique", "required"}); !best.empty()) {
            r.fail(r.path(it.key()), fmt::format("unknown key; did you mean \"{}\"?", best));
        }
        if (s.unshadowed()) r.fail(r.path(it.key()), "technique \"none\" (an unshadowed light) takes no parameters");
        s.params.push_back({it.key(), it.value(), light.locator().where(r.path(it.key()))});
    }
    return s;
}

// The unit axis of a light: from "direction", or from "target" minus the position.
void readAxis(ObjectReader& r, LightConfig& lc, bool positioned)
{
    const std::string& at = r.pointer();
    const json* direction = r.find("direction");
    const json* target = r.find("target");
    // Aiming a sun from a position it does not have would give a direction that depends
    // on an invisible default: "direction" says what is meant.
    if (target && !positioned) {
        r.fail(at + "/target", "a directional light has no position to aim from: give its \"direction\" (the way its "
                               "light travels) instead");
    }
    if (direction && target) r.fail(at, "give either \"direction\" or \"target\", not both");
    if (!direction && !target) r.fail(at + (positioned ? "/target" : "/direction"), "is required but missing");
    if (target) {
        lc.target = r.checkVec3(*target, at + "/target");
        if (!(glm::length(*lc.target - lc.light.position) > 0.0f)) r.fail(at + "/target", "must differ from position");
        lc.light.direction = glm::normalize(*lc.target - lc.light.position);
    } else {
        const glm::vec3 d = r.checkVec3(*direction, at + "/direction");
        if (!(glm::length(d) > 0.0f)) r.fail(at + "/direction", "must be non-zero");
        lc.light.direction = glm::normalize(d);
    }
}

LightConfig readLight(const json& v, const Locator& locator, size_t index)
{
    const std::string at = fmt::format("/lights/{}", index);
    LightConfig lc;
    ObjectReader r(v, locator, at);
    const std::string type = r.choice("type", "spot", {"directional", "spot", "point", "rect", "disk"});
    scene::Light& l = lc.light;
    lc.name = r.string("name", fmt::format("light{}", index));
    l.intensity = float(r.number("intensity", l.intensity, 0.0, 1e12));
    l.color = r.vec3("color", l.color);
    if (glm::any(glm::lessThan(l.color, glm::vec3(0.0f)))) r.fail(at + "/color", "components must be >= 0");
    if (type == "directional") {
        l.type = scene::LightType::Directional;
        readAxis(r, lc, false);
        l.angularDiameterDeg = float(r.number("angular_diameter_deg", 0.0, 0.0, 90.0));
    } else {
        l.position = r.vec3("position", l.position, true);
        if (type == "spot") {
            l.type = scene::LightType::Spot;
            readAxis(r, lc, true);
            l.outerConeDeg = float(r.number("outer_cone_deg", l.outerConeDeg, 0.0, 89.0, true));
            l.innerConeDeg = float(r.number("inner_cone_deg", std::min(l.innerConeDeg, l.outerConeDeg), 0.0, 89.0));
            if (l.innerConeDeg > l.outerConeDeg) {
                r.fail(at + "/inner_cone_deg", fmt::format("must be <= outer_cone_deg ({}), got {}", l.outerConeDeg, l.innerConeDeg));
            }
        } else if (type == "point") {
            l.type = scene::LightType::Point;
            l.radiusWorld = float(r.number("radius", 0.0, 0.0, 1e9));
        } else if (type == "rect") {
            l.type = scene::LightType::Rect;
            readAxis(r, lc, true);
            const json& size = r.require("size");
            if (!size.is_array() || size.size() != 2) r.fail(at + "/size", fmt::format("must be [width, height], got {}", core::shortJson(size)));
            // 0 is a size (a line, or with both a point that emits like a rect): every
            // technique and the reference take it, so that a sweep can reach the limit.
            for (int i = 0; i < 2; ++i) l.sizeWorld[i] = float(r.checkNumber(size[size_t(i)], fmt::format("{}/size/{}", at, i), 0.0, 1e9, false));
            // The width axis: "tangent" projected onto the emitting plane, else any axis in it.
            glm::vec3 t = r.vec3("tangent", glm::abs(l.direction.y) < 0.9f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0));
            t -= glm::dot(t, l.direction) * l.direction;
            if (!(glm::length(t) > 1e-4f)) r.fail(at + "/tangent", "must not be parallel to the light's direction");
            l.tangent = glm::normalize(t);
        } else {
            l.type = scene::LightType::Disk;
            readAxis(r, lc, true);
            l.radiusWorld = float(r.number("radius", 0.0, 0.0, 1e9));  // 0: a point, as for rect's size
            if (!r.find("radius")) r.fail(at + "/radius", "is required but missing");
        }
    }
    lc.shadow = readShadow(r);
    r.finish(fmt::format("for a {} light", type));
    return lc;
}

CullingMode readCulling(ObjectReader& r)
{
    const std::string mode = r.choice("culling", "none", {"none", "frustum", "light-occlusion", "receiver-mask"});
    if (mode == "frustum") return CullingMode::Frustum;
    if (mode == "light-occlusion") return CullingMode::LightOcclusion;
    if (mode == "receiver-mask") return CullingMode::ReceiverMask;
    return CullingMode::None;
}

} // namespace

CullingMode parseCullingMode(std::string_view name)
{
    for (const CullingMode m :
         {CullingMode::None, CullingMode::Frustum, CullingMode::LightOcclusion, CullingMode::ReceiverMask}) {
        if (name == cullingModeName(m)) return m;
    }
    throw ConfigError(fmt::format("culling: '{}' is not a mode; expected none, frustum, light-occlusion or "
                                  "receiver-mask",
                                  core::shortText(name)));
}

const char* cullingModeName(CullingMode mode)
{
    switch (mode) {
    case CullingMode::None: return "none";
    case CullingMode::Frustum: return "frustum";
    case CullingMode::LightOcclusion: return "light-occlusion";
    case CullingMode::ReceiverMask: return "receiver-mask";
    }
    return "unknown";
}

const nlohmann::json* ShadowSettings::param(std::string_view name) const
{
    for (const ShadowParam& p : params)
        if (p.name == name) return &p.value;
    return nullptr;
}

void ShadowSettings::setParam(std::string name, nlohmann::json value, std::string where)
{
    for (ShadowParam& p : params)
        if (p.name == name) {
            p.value = std::move(value);
            p.where = std::move(where);
            return;
        }
    params.push_back({std::move(name), std::move(value), std::move(where)});
}

RenderConfig parseConfig(const ConfigDocument& document)
{
    const Locator locator(document);
    RenderConfig config;
    config.file = document.file;
    ObjectReader r(document.json, locator, "");
    r.find("sweep");  // made into variants by SweepVariants; the base run ignores it
    // Editors read "$schema" (config/schema/penumbra-config.schema.json); the engine has
    // its own checks.
    if (const json* schema = r.find("$schema"); schema && !schema->is_string()) {
        r.fail("/$schema", fmt::format("must be the JSON Schema's path or URL (a string), got {}", core::shortJson(*schema)));
    }
    config.scene = readScene(r, document.file);
    config.camera = readCamera(r);
    const json& lights = r.require("lights");
    if (lights.is_string() && lights.get<std::string>() == "scene") {
        if (!config.scene.hasGltf()) {
            r.fail("/lights", "\"scene\" takes the lights of a glTF scene, but /scene has no glTF file (only generators)");
        }
        config.lightsFromScene = true;
    } else if (!lights.is_array() || lights.empty()) {
        r.fail("/lights", "must be a non-empty array of lights, or \"scene\" for a glTF file's own lights");
    }
    if (lights.is_array() && lights.size() > kMaxLights) {
        r.fail("/lights", fmt::format("at most {} lights, got {}", kMaxLights, lights.size()));
    }
    std::set<std::string> names;
    for (size_t i = 0; lights.is_array() && i < lights.size(); ++i) {
        config.lights.push_back(readLight(lights[i], locator, i));
        if (!names.insert(config.lights.back().name).second) {
            r.fail(fmt::format("/lights/{}/name", i), fmt::format("duplicate light name {}", core::shortJson(config.lights.back().name)));
        }
    }
    config.culling = readCulling(r);
    if (const json* focus = r.find("shadow_focus")) {
        if (!focus->is_boolean()) r.fail("/shadow_focus", fmt::format("must be true or false, got {}", core::shortJson(*focus)));
        config.shadowFocus = focus->get<bool>();
        // Focusing needs what the camera sees: the occlusion modes' camera depth.
        if (config.shadowFocus && config.culling != CullingMode::ReceiverMask &&
            config.culling != CullingMode::LightOcclusion) {
            r.fail("/shadow_focus", fmt::format("needs culling \"receiver-mask\" (or \"light-occlusion\"), which "
                                                "find what the camera sees; culling is \"{}\"",
                                                cullingModeName(config.culling)));
        }
    }
    if (const json* culling = r.find("light_culling")) {
        if (!culling->is_boolean()) {
            r.fail("/light_culling", fmt::format("must be true or false, got {}", core::shortJson(*culling)));
        }
        config.lightCulling = culling->get<bool>();
    }
    if (const json* keep = r.find("keep_unchanged")) {
        if (!keep->is_boolean()) {
            r.fail("/keep_unchanged", fmt::format("must be true or false, got {}", core::shortJson(*keep)));
        }
        config.keepUnchanged = keep->get<bool>();
    }
    config.maxShadowedLights = r.integer("max_shadowed_lights", config.maxShadowedLights, 1, kMaxLights);
    config.batchDraws = r.choice("draw_batching", "batched", {"batched", "per-instance"}) == "batched";
    if (const json* out = r.find("output")) {
        ObjectReader o(*out, locator, "/output");
        config.width = o.integer("width", config.width, 1, 16384);
        config.height = o.integer("height", config.height, 1, 16384);
        o.finish();
    }
    config.frames = r.integer("frames", config.frames, 1, kMaxFrames);
    config.animation = readAnimation(r, config.lights, config.scene.playsClip());
    if (const json* notes = r.find("notes")) {
        if (!notes->is_array()) r.fail("/notes", fmt::format("must be an array of Markdown paragraphs (strings), got {}", core::shortJson(*notes)));
        for (size_t i = 0; i < notes->size(); ++i) {
            const json& note = (*notes)[i];
            if (!note.is_string() || note.get<std::string>().empty()) {
                r.fail(fmt::format("/notes/{}", i), fmt::format("must be a non-empty string (a Markdown paragraph), got {}", core::shortJson(note)));
            }
            config.notes.push_back(note.get<std::string>());
        }
    }
    r.finish();
    return config;
}

RenderConfig parseConfig(const json& value, const fs::path& file)
{
    ConfigDocument document;
    document.file = file;
    document.json = value;
    return parseConfig(document);
}

RenderConfig loadConfig(const fs::path& file) { return parseConfig(loadDocument(file)); }

} // namespace penumbra::config
