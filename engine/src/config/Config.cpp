#define GLM_ENABLE_EXPERIMENTAL  // glm/gtx: euler angles and matrix decomposition for node tracks
#include "penumbra/config/Config.h"

#include "core/Text.h"
#include "penumbra/core/Error.h"
#include "penumbra/scene/GltfLoader.h"

#include <fmt/format.h>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtx/euler_angles.hpp>
#include <glm/gtx/matrix_decompose.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <functional>
#include <set>

using nlohmann::json;
namespace fs = std::filesystem;

namespace penumbra::config {
namespace {

// Where messages point: the file a JSON path's value came from.
class Locator {
public:
    explicit Locator(const ConfigDocument& document) : document_(document) {}
    // "file: /json/pointer", for values whose checking happens later (plugin parameters).
    std::string where(const std::string& pointer) const { return fmt::format("{}: {}", document_.fileFor(pointer), pointer); }
    [[noreturn]] void fail(const std::string& pointer, const std::string& what) const
    {
        throw ConfigError(fmt::format("{}: {}: {}", document_.fileFor(pointer), pointer.empty() ? "/" : pointer, what));
    }

private:
    const ConfigDocument& document_;
};

// One JSON object being read: remembers which keys were consumed so that unknown keys
// (typos) are errors, with a suggestion when a known key is close.
class ObjectReader {
public:
    ObjectReader(const json& value, const Locator& locator, std::string pointer)
        : value_(value), locator_(locator), pointer_(std::move(pointer))
    {
        if (!value_.is_object()) fail(pointer_, fmt::format("must be an object, got {}", value_.type_name()));
    }

    [[noreturn]] void fail(const std::string& pointer, const std::string& what) const { locator_.fail(pointer, what); }

    std::string path(const std::string& key) const { return pointer_ + "/" + key; }
    const std::string& pointer() const { return pointer_; }
    const Locator& locator() const { return locator_; }

    const json* find(const std::string& key)
    {
        known_.insert(key);
        auto it = value_.find(key);
        return it == value_.end() ? nullptr : &*it;
    }

    const json& require(const std::string& key)
    {
        const json* v = find(key);
        if (!v) fail(path(key), "is required but missing");
        return *v;
    }

    double number(const std::string& key, double fallback, double lo, double hi, bool loOpen = false)
    {
        const json* v = find(key);
        return v ? checkNumber(*v, path(key), lo, hi, loOpen) : fallback;
    }

    double checkNumber(const json& v, const std::string& at, double lo, double hi, bool loOpen) const
    {
        if (!v.is_number()) fail(at, fmt::format("must be a number, got {}", v.dump()));
        const double x = v.get<double>();
        const bool below = loOpen ? x <= lo : x < lo;
        if (!std::isfinite(x) || below || x > hi) {
            fail(at, fmt::format("must be in {}{}, {}], got {}", loOpen ? "(" : "[", lo, hi, v.dump()));
        }
        return x;
    }

    uint32_t integer(const std::string& key, uint32_t fallback, uint32_t lo, uint32_t hi)
    {
        const json* v = find(key);
        if (!v) return fallback;
        if (!v->is_number_integer()) fail(path(key), fmt::format("must be an integer, got {}", v->dump()));
        const int64_t x = v->get<int64_t>();
        if (x < int64_t(lo) || x > int64_t(hi)) {
            fail(path(key), fmt::format("must be an integer in [{}, {}], got {}", lo, hi, x));
        }
        return static_cast<uint32_t>(x);
    }

    glm::vec3 vec3(const std::string& key, glm::vec3 fallback, bool required = false)
    {
        const json* v = required ? &require(key) : find(key);
        return v ? checkVec3(*v, path(key)) : fallback;
    }

    glm::vec3 checkVec3(const json& v, const std::string& at) const
    {
        if (!v.is_array() || v.size() != 3 ||
            !std::all_of(v.begin(), v.end(), [](const json& e) { return e.is_number(); })) {
            fail(at, fmt::format("must be an array of 3 numbers, got {}", v.dump()));
        }
        glm::vec3 out;
        for (int i = 0; i < 3; ++i) {
            const double x = v[size_t(i)].get<double>();
            if (!std::isfinite(x) || std::abs(x) > 3.0e38) fail(at, fmt::format("must be finite, got {}", v.dump()));
            out[i] = float(x);
        }
        return out;
    }

    std::string choice(const std::string& key, const std::string& fallback, const std::vector<std::string>& allowed)
    {
        const json* v = find(key);
        if (!v) return fallback;
        if (!v->is_string()) fail(path(key), fmt::format("must be a string, got {}", v->dump()));
        const std::string s = v->get<std::string>();
        if (std::find(allowed.begin(), allowed.end(), s) == allowed.end()) {
            fail(path(key), fmt::format("must be one of {}, got \"{}\"", fmt::join(allowed, ", "), s));
        }
        return s;
    }

    std::string string(const std::string& key, const std::string& fallback)
    {
        const json* v = find(key);
        if (!v) return fallback;
        if (!v->is_string() || v->get<std::string>().empty()) fail(path(key), fmt::format("must be a non-empty string, got {}", v->dump()));
        return v->get<std::string>();
    }

    // Unknown keys are errors: a typo must not silently fall back to a default.
    // `context` says for what the keys were expected ("for a point light").
    void finish(const std::string& context = "") const
    {
        for (auto it = value_.begin(); it != value_.end(); ++it) {
            if (known_.count(it.key())) continue;
            const std::vector<std::string> keys(known_.begin(), known_.end());
            const std::string best = core::closestMatch(it.key(), keys);
            const std::string unknown = context.empty() ? "unknown key" : "unknown key " + context;
            fail(path(it.key()), best.empty() ? fmt::format("{} (expected one of: {})", unknown, fmt::join(keys, ", "))
                                              : fmt::format("{}; did you mean \"{}\"?", unknown, best));
        }
    }

private:
    const json& value_;
    const Locator& locator_;
    std::string pointer_;
    std::set<std::string> known_;
};

SceneSource readScene(ObjectReader& parent, const fs::path& configFile)
{
    SceneSource source;
    const json* v = parent.find("scene");
    if (!v) return source;
    ObjectReader r(*v, parent.locator(), "/scene");
    const json* gltf = r.find("gltf");
    const json* generator = r.find("generator");
    if (gltf && generator) r.fail("/scene", "give either \"gltf\" or \"generator\", not both");
    source.scale = float(r.number("scale", 1.0, 0.0, 1e9, true));
    if (gltf) {
        source.kind = SceneSource::Kind::Gltf;
        if (!gltf->is_string() || gltf->get<std::string>().empty()) r.fail("/scene/gltf", "must be a file path");
        source.gltf = gltf->get<std::string>();
        if (source.gltf.is_relative()) source.gltf = configFile.parent_path() / source.gltf;
        std::error_code ec;
        if (!fs::is_regular_file(source.gltf, ec)) r.fail("/scene/gltf", fmt::format("file not found: {}", source.gltf.string()));
        r.finish();
        return source;
    }
    source.generator = r.choice("generator", source.generator, scene::generatorNames());
    if (const json* params = r.find("params")) {
        ObjectReader p(*params, parent.locator(), "/scene/params");
        for (const scene::GeneratorParameter& parameter : scene::generatorParameters(source.generator)) {
            const json* v = p.find(parameter.name);
            if (!v) continue;
            if (!v->is_number() && !v->is_boolean() && !v->is_string()) {
                p.fail(p.path(parameter.name), fmt::format("must be a number, got {}", v->dump()));
            }
            source.params.emplace_back(parameter.name, v->is_string() ? v->get<std::string>() : v->dump());
        }
        p.finish(fmt::format("for the {} generator", source.generator));
    }
    r.finish();
    return source;
}

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
    const bool nameOk = std::all_of(s.technique.begin(), s.technique.end(), [](char c) {
        return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
    });
    if (!nameOk) r.fail(r.path("technique"), fmt::format("must be a plugin name ([a-z0-9_-]+), got \"{}\"", s.technique));
    if (const json* required = r.find("required")) {
        if (!required->is_boolean()) r.fail(r.path("required"), fmt::format("must be true or false, got {}", required->dump()));
        s.required = required->get<bool>();
    }
    // Every other key is a parameter of the technique: its plugin's reflection checks
    // name, type and range when the technique is created.
    for (auto it = v->begin(); it != v->end(); ++it) {
        if (it.key() == "technique" || it.key() == "required") continue;
        s.params.push_back({it.key(), it.value(), light.locator().where(r.path(it.key()))});
    }
    return s;
}

// The unit axis of a light: from "direction", or from "target" minus the position.
void readAxis(ObjectReader& r, LightConfig& lc, bool positioned)
{
    const std::string& at = r.pointer();
    const json* direction = r.find("direction");
    const json* target = positioned ? r.find("target") : nullptr;
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
            if (!size.is_array() || size.size() != 2) r.fail(at + "/size", fmt::format("must be [width, height], got {}", size.dump()));
            for (int i = 0; i < 2; ++i) l.sizeWorld[i] = float(r.checkNumber(size[size_t(i)], fmt::format("{}/size/{}", at, i), 0.0, 1e9, true));
            // The width axis: "tangent" projected onto the emitting plane, else any axis in it.
            glm::vec3 t = r.vec3("tangent", glm::abs(l.direction.y) < 0.9f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0));
            t -= glm::dot(t, l.direction) * l.direction;
            if (!(glm::length(t) > 1e-4f)) r.fail(at + "/tangent", "must not be parallel to the light's direction");
            l.tangent = glm::normalize(t);
        } else {
            l.type = scene::LightType::Disk;
            readAxis(r, lc, true);
            l.radiusWorld = float(r.number("radius", 0.0, 0.0, 1e9, true));
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

// How many numbers an animation target takes, or 0 when the target is unknown.
size_t targetSize(const std::string& target, size_t lightCount, std::string& why)
{
    static const std::vector<std::pair<std::string, size_t>> camera = {
        {"/camera/position", 3}, {"/camera/target", 3}, {"/camera/fov_y_deg", 1}};
    for (const auto& [name, n] : camera) {
        if (target == name) return n;
    }
    if (target.rfind("/lights/", 0) == 0) {
        const size_t slash = target.find('/', 8);
        const std::string index = target.substr(8, slash == std::string::npos ? std::string::npos : slash - 8);
        const std::string field = slash == std::string::npos ? "" : target.substr(slash + 1);
        const bool digits = !index.empty() && index.size() <= 3 &&
                            std::all_of(index.begin(), index.end(), [](unsigned char c) { return std::isdigit(c) != 0; });
        if (!digits || std::stoul(index) >= lightCount) {
            why = fmt::format("light index '{}' is not one of the {} configured lights", index, lightCount);
            return 0;
        }
        static const std::vector<std::pair<std::string, size_t>> fields = {
            {"position", 3}, {"target", 3}, {"intensity", 1}, {"color", 3}};
        for (const auto& [name, n] : fields) {
            if (field == name) return n;
        }
        why = fmt::format("a light's animatable values are position, target, intensity and color, got '{}'", field);
        return 0;
    }
    if (target.rfind("node:", 0) == 0) {
        const size_t slash = target.rfind('/');
        const std::string field = slash == std::string::npos ? "" : target.substr(slash + 1);
        if (slash == std::string::npos || slash <= 5) {
            why = "expected node:<name>/translation, node:<name>/rotation_deg or node:<name>/scale";
            return 0;
        }
        if (field == "translation" || field == "rotation_deg" || field == "scale") return 3;
        why = fmt::format("a node's animatable values are translation, rotation_deg and scale, got '{}'", field);
        return 0;
    }
    why = "expected /camera/..., /lights/<i>/... or node:<name>/...";
    return 0;
}

Animation readAnimation(ObjectReader& parent, size_t lightCount)
{
    Animation animation;
    const json* v = parent.find("animation");
    if (!v) return animation;
    ObjectReader r(*v, parent.locator(), "/animation");
    animation.fps = float(r.number("fps", animation.fps, 0.0, 10000.0, true));
    const json& tracks = r.require("tracks");
    if (!tracks.is_array()) r.fail("/animation/tracks", "must be an array of tracks");
    for (size_t i = 0; i < tracks.size(); ++i) {
        const std::string at = fmt::format("/animation/tracks/{}", i);
        ObjectReader t(tracks[i], parent.locator(), at);
        AnimationTrack track;
        const json& target = t.require("target");
        if (!target.is_string()) t.fail(at + "/target", "must be a string");
        track.target = target.get<std::string>();
        std::string why;
        const size_t size = targetSize(track.target, lightCount, why);
        if (size == 0) t.fail(at + "/target", fmt::format("unknown target \"{}\": {}", track.target, why));
        const std::string interp = t.choice("interpolation", "linear", {"step", "linear", "smooth"});
        track.interpolation = interp == "step" ? Interpolation::Step
                              : interp == "smooth" ? Interpolation::Smooth : Interpolation::Linear;
        const json& keys = t.require("keys");
        if (!keys.is_array() || keys.empty()) t.fail(at + "/keys", "must be a non-empty array of {\"t\": seconds, \"value\": ...}");
        for (size_t k = 0; k < keys.size(); ++k) {
            const std::string kat = fmt::format("{}/keys/{}", at, k);
            ObjectReader key(keys[k], parent.locator(), kat);
            Keyframe frame;
            frame.timeS = float(key.number("t", 0.0, 0.0, 1e9));
            if (!key.find("t")) key.fail(kat + "/t", "is required but missing");
            const json& value = key.require("value");
            if (size == 1 && value.is_number()) {
                frame.value = {float(key.checkNumber(value, kat + "/value", -3e38, 3e38, false))};
            } else if (size == 3) {
                const glm::vec3 x = key.checkVec3(value, kat + "/value");
                frame.value = {x.x, x.y, x.z};
            } else {
                key.fail(kat + "/value", fmt::format("must be {} for {}", size == 1 ? "a number" : "an array of 3 numbers", track.target));
            }
            if (!track.keys.empty() && !(frame.timeS > track.keys.back().timeS)) {
                key.fail(kat + "/t", fmt::format("key times must increase strictly: {} after {}", frame.timeS, track.keys.back().timeS));
            }
            key.finish();
            track.keys.push_back(std::move(frame));
        }
        t.finish();
        animation.tracks.push_back(std::move(track));
    }
    r.finish();
    return animation;
}

// Records, for every JSON path in `value`, that it came from `file`.
void recordOrigin(const json& value, const std::string& pointer, const std::string& file,
                  std::map<std::string, std::string>& origin)
{
    origin[pointer] = file;
    if (value.is_object()) {
        for (auto it = value.begin(); it != value.end(); ++it) recordOrigin(*it, pointer + "/" + it.key(), file, origin);
    } else if (value.is_array()) {
        for (size_t i = 0; i < value.size(); ++i) recordOrigin(value[i], fmt::format("{}/{}", pointer, i), file, origin);
    }
}

json readJson(const fs::path& file)
{
    std::error_code ec;
    if (!fs::exists(file, ec)) throw ConfigError(fmt::format("{}: config file not found", file.string()));
    if (fs::is_directory(file, ec)) throw ConfigError(fmt::format("{}: is a directory, expected a JSON config file", file.string()));
    std::ifstream in(file, std::ios::binary);
    if (!in) throw ConfigError(fmt::format("{}: cannot open config file for reading", file.string()));
    try {
        return json::parse(in);
    } catch (const json::parse_error& e) {
        // nlohmann's message carries line and column: "parse error at line 3, column 5: ...".
        std::string what = e.what();
        if (auto pos = what.find("parse error"); pos != std::string::npos) what = what.substr(pos);
        throw ConfigError(fmt::format("{}: malformed JSON: {}", file.string(), what));
    }
}

ConfigDocument loadWithIncludes(const fs::path& file, std::vector<fs::path>& chain)
{
    const fs::path canonical = fs::weakly_canonical(file);
    ConfigDocument doc;
    doc.file = file;
    json own = readJson(file);
    if (!own.is_object()) throw ConfigError(fmt::format("{}: /: must be an object, got {}", file.string(), own.type_name()));
    chain.push_back(canonical);
    doc.json = json::object();
    if (auto it = own.find("include"); it != own.end()) {
        std::vector<std::string> includes;
        if (it->is_string()) {
            includes.push_back(it->get<std::string>());
        } else if (it->is_array() && std::all_of(it->begin(), it->end(), [](const json& e) { return e.is_string(); })) {
            for (const json& e : *it) includes.push_back(e.get<std::string>());
        } else {
            throw ConfigError(fmt::format("{}: /include: must be a file name or an array of file names, got {}",
                                          file.string(), it->dump()));
        }
        for (size_t i = 0; i < includes.size(); ++i) {
            fs::path path = includes[i];
            if (path.is_relative()) path = file.parent_path() / path;
            if (std::find(chain.begin(), chain.end(), fs::weakly_canonical(path)) != chain.end()) {
                std::string cycle;
                for (const fs::path& p : chain) cycle += p.filename().string() + " -> ";
                throw ConfigError(fmt::format("{}: /include/{}: include cycle: {}{}", file.string(), i, cycle,
                                              path.filename().string()));
            }
            std::error_code ec;
            if (!fs::exists(path, ec)) {
                throw ConfigError(fmt::format("{}: /include{}: included file not found: {}", file.string(),
                                              it->is_string() ? "" : fmt::format("/{}", i), path.string()));
            }
            ConfigDocument included = loadWithIncludes(path, chain);
            doc.json.merge_patch(included.json);
            for (auto& [pointer, origin] : included.origin) doc.origin[pointer] = origin;
        }
        own.erase("include");
    }
    chain.pop_back();
    doc.json.merge_patch(own);
    recordOrigin(own, "", file.string(), doc.origin);
    return doc;
}

glm::mat4 composeTrs(const glm::vec3& t, const glm::quat& r, const glm::vec3& s)
{
    return glm::translate(glm::mat4(1.0f), t) * glm::mat4_cast(r) * glm::scale(glm::mat4(1.0f), s);
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
                                  name));
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

std::string ConfigDocument::fileFor(const std::string& pointer) const
{
    // The nearest recorded ancestor: a key that is missing was missing in the file that
    // holds its parent object.
    std::string p = pointer;
    while (true) {
        if (auto it = origin.find(p); it != origin.end()) return it->second;
        if (p.empty()) return file.string();
        p = p.substr(0, p.rfind('/'));
    }
}

ConfigDocument loadDocument(const fs::path& file)
{
    std::vector<fs::path> chain;
    return loadWithIncludes(file, chain);
}

RenderConfig parseConfig(const ConfigDocument& document)
{
    const Locator locator(document);
    RenderConfig config;
    config.file = document.file;
    ObjectReader r(document.json, locator, "");
    r.find("sweep");  // expanded by expandSweep(); the base run ignores it
    config.scene = readScene(r, document.file);
    config.camera = readCamera(r);
    const json& lights = r.require("lights");
    if (lights.is_string() && lights.get<std::string>() == "scene") {
        if (config.scene.kind != SceneSource::Kind::Gltf) {
            r.fail("/lights", "\"scene\" takes the lights of a glTF scene, but /scene is a generator");
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
            r.fail(fmt::format("/lights/{}/name", i), fmt::format("duplicate light name \"{}\"", config.lights.back().name));
        }
    }
    config.culling = readCulling(r);
    if (const json* focus = r.find("shadow_focus")) {
        if (!focus->is_boolean()) r.fail("/shadow_focus", fmt::format("must be true or false, got {}", focus->dump()));
        config.shadowFocus = focus->get<bool>();
        // Focusing needs what the camera sees: the occlusion modes' camera depth.
        if (config.shadowFocus && config.culling != CullingMode::ReceiverMask &&
            config.culling != CullingMode::LightOcclusion) {
            r.fail("/shadow_focus", fmt::format("needs culling \"receiver-mask\" (or \"light-occlusion\"), which "
                                                "find what the camera sees; culling is \"{}\"",
                                                cullingModeName(config.culling)));
        }
    }
    if (const json* out = r.find("output")) {
        ObjectReader o(*out, locator, "/output");
        config.width = o.integer("width", config.width, 1, 16384);
        config.height = o.integer("height", config.height, 1, 16384);
        o.finish();
    }
    config.frames = r.integer("frames", config.frames, 1, 1000000);
    config.animation = readAnimation(r, config.lights.size());
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

namespace {

// One sweep entry: the JSON pointers it sets together and the values it takes.
struct SweepAxis {
    std::vector<json::json_pointer> paths;
    std::vector<std::string> pathTexts;
    std::vector<json> values;          // per value: one JSON value per path
    std::vector<std::string> labels;   // per value: "labels"[i], or the value as JSON
    bool labelled = false;             // "labels" was given
};

json::json_pointer readSweepPointer(const json& text, const ObjectReader& r, const std::string& at)
{
    if (!text.is_string()) r.fail(at, "must be a JSON pointer string such as \"/lights/0/shadow/resolution\"");
    const std::string s = text.get<std::string>();
    json::json_pointer pointer;
    try {
        pointer = json::json_pointer(s);
    } catch (const json::exception& e) {
        r.fail(at, fmt::format("\"{}\" is not a JSON pointer ({})", s, e.what()));
    }
    if (s.empty() || s.rfind("/sweep", 0) == 0 || s.rfind("/include", 0) == 0) r.fail(at, fmt::format("cannot sweep \"{}\"", s));
    return pointer;
}

// "path": one pointer, each value sets it; "paths": several pointers set together (a
// scene with its camera), each value an array with one entry per path. "labels" names
// the values for tables and plots.
SweepAxis readSweepAxis(const json& entry, const Locator& locator, const std::string& at)
{
    ObjectReader r(entry, locator, at);
    const json* path = r.find("path");
    const json* paths = r.find("paths");
    const json& values = r.require("values");
    const json* labels = r.find("labels");
    r.finish();
    SweepAxis axis;
    if ((path != nullptr) == (paths != nullptr)) r.fail(at, "give either \"path\" (one JSON pointer) or \"paths\" (several)");
    if (path) {
        axis.paths.push_back(readSweepPointer(*path, r, at + "/path"));
    } else {
        if (!paths->is_array() || paths->empty()) r.fail(at + "/paths", "must be a non-empty array of JSON pointers");
        for (size_t k = 0; k < paths->size(); ++k) {
            axis.paths.push_back(readSweepPointer((*paths)[k], r, fmt::format("{}/paths/{}", at, k)));
        }
    }
    for (const json::json_pointer& p : axis.paths) axis.pathTexts.push_back(p.to_string());
    for (size_t a = 0; a < axis.paths.size(); ++a) {
        for (size_t b = 0; b < axis.paths.size(); ++b) {
            const std::string& outer = axis.pathTexts[a];
            const std::string& inner = axis.pathTexts[b];
            if (a != b && inner.rfind(outer, 0) == 0 && (inner.size() == outer.size() || inner[outer.size()] == '/')) {
                r.fail(fmt::format("{}/paths/{}", at, b), fmt::format("\"{}\" lies inside \"{}\", which the same entry sets",
                                                                      inner, outer));
            }
        }
    }
    if (!values.is_array() || values.empty()) r.fail(at + "/values", "must be a non-empty array");
    for (size_t i = 0; i < values.size(); ++i) {
        if (paths && (!values[i].is_array() || values[i].size() != axis.paths.size())) {
            r.fail(fmt::format("{}/values/{}", at, i),
                   fmt::format("must be an array of {} values, one per path, got {}", axis.paths.size(), values[i].dump()));
        }
        axis.values.push_back(values[i]);
    }
    if (labels) {
        if (!labels->is_array() || labels->size() != values.size()) {
            r.fail(at + "/labels", fmt::format("must be an array of {} strings, one per value", values.size()));
        }
        for (size_t i = 0; i < labels->size(); ++i) {
            const json& label = (*labels)[i];
            const std::string where = fmt::format("{}/labels/{}", at, i);
            if (!label.is_string() || label.get<std::string>().empty()) r.fail(where, fmt::format("must be a non-empty string, got {}", label.dump()));
            if (std::find(axis.labels.begin(), axis.labels.end(), label.get<std::string>()) != axis.labels.end()) {
                r.fail(where, fmt::format("\"{}\" labels another value already", label.get<std::string>()));
            }
            axis.labels.push_back(label.get<std::string>());
        }
        axis.labelled = true;
    } else {
        for (const json& v : axis.values) axis.labels.push_back(v.dump());
    }
    return axis;
}

// Sets `pointer` in `doc` to `value`. The parent must exist (a missing one is a typo far
// more often than an intent) and, when it is an array, hold the element: setting past
// the end would pad the array with nulls.
void setSwept(json& doc, const json::json_pointer& pointer, const json& value, const Locator& locator,
              const std::string& at, const std::string& variant)
{
    const std::string text = pointer.to_string();
    const json::json_pointer parent = pointer.parent_pointer();
    const std::string in = variant.empty() ? "" : fmt::format(" (in the variant {})", variant);
    if (!doc.contains(parent) || !(doc[parent].is_object() || doc[parent].is_array())) {
        locator.fail(at, fmt::format("\"{}\": the config has no \"{}\" to set it in{}", text, parent.to_string(), in));
    }
    if (doc[parent].is_array()) {
        const std::string& index = pointer.back();
        const bool digits = !index.empty() && std::all_of(index.begin(), index.end(), [](unsigned char c) { return std::isdigit(c); });
        if (!digits || index.size() > 9 || std::stoul(index) >= doc[parent].size()) {
            locator.fail(at, fmt::format("\"{}\": \"{}\" has {} elements; a sweep replaces an element, it does not add one{}",
                                         text, parent.to_string(), doc[parent].size(), in));
        }
    }
    doc[pointer] = value;
}

} // namespace

std::vector<SweepVariant> expandSweep(const ConfigDocument& document)
{
    const Locator locator(document);
    auto it = document.json.find("sweep");
    if (it == document.json.end()) return {{"", {}, parseConfig(document)}};
    const json& sweep = *it;
    if (!sweep.is_array() || sweep.empty()) locator.fail("/sweep", "must be a non-empty array of {\"path\", \"values\"}");
    std::vector<SweepAxis> axes;
    size_t combinations = 1;
    for (size_t i = 0; i < sweep.size(); ++i) {
        const std::string at = fmt::format("/sweep/{}", i);
        axes.push_back(readSweepAxis(sweep[i], locator, at));
        combinations *= axes.back().values.size();
        if (combinations > 100000) locator.fail(at + "/values", "the sweep has more than 100000 combinations");
    }
    std::vector<SweepVariant> variants;
    for (size_t c = 0; c < combinations; ++c) {
        // The first entry varies slowest. Entries are applied in order, so a later one may
        // set a value inside one that an earlier entry replaced (a technique's parameter
        // inside a swept "shadow" object).
        std::vector<size_t> picks(axes.size());
        for (size_t a = axes.size(), rest = c; a-- > 0; rest /= axes[a].values.size()) picks[a] = rest % axes[a].values.size();
        ConfigDocument variant = document;
        variant.json.erase("sweep");
        SweepVariant out;
        std::vector<std::string> label;
        for (size_t a = 0; a < axes.size(); ++a) {
            const SweepAxis& axis = axes[a];
            const size_t pick = picks[a];
            const bool several = axis.paths.size() > 1;
            for (size_t k = 0; k < axis.paths.size(); ++k) {
                const std::string& text = axis.pathTexts[k];
                const std::string at = several ? fmt::format("/sweep/{}/paths/{}", a, k) : fmt::format("/sweep/{}/path", a);
                setSwept(variant.json, axis.paths[k], several ? axis.values[pick][k] : axis.values[pick], locator, at,
                         fmt::format("{}", fmt::join(label, ", ")));
                // The value replaced whatever was there, including where its parts came from.
                for (auto o = variant.origin.lower_bound(text); o != variant.origin.end() && o->first.rfind(text, 0) == 0;) {
                    const bool inside = o->first.size() == text.size() || o->first[text.size()] == '/';
                    o = inside ? variant.origin.erase(o) : std::next(o);
                }
                variant.origin[text] = several ? fmt::format("{} (/sweep/{}/values/{}/{})", document.file.string(), a, pick, k)
                                               : fmt::format("{} (/sweep/{}/values/{})", document.file.string(), a, pick);
            }
            label.push_back(fmt::format("{}={}", fmt::join(axis.pathTexts, "+"), axis.labels[pick]));
            out.choices.push_back({axis.pathTexts, pick, axis.labels[pick], axis.labelled});
        }
        out.label = fmt::format("{}", fmt::join(label, ", "));
        out.config = parseConfig(variant);
        variants.push_back(std::move(out));
    }
    return variants;
}

scene::Scene buildScene(const SceneSource& source, std::vector<scene::Light>* fileLights)
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
            scene::Light light = l.light;
            // Scaling the scene about the origin moves its lights with it; radiant
            // intensity times s² keeps the irradiance it gives the scaled scene.
            light.position *= source.scale;
            if (light.type != scene::LightType::Directional) light.intensity *= source.scale * source.scale;
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
    std::vector<scene::Light> fileLights;
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
        for (size_t i = 0; i < fileLights.size(); ++i) {
            LightConfig lc;
            lc.name = fmt::format("light{}", i);
            lc.light = fileLights[i];
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

void applyAnimation(const Animation& animation, float timeS, RenderConfig& config, scene::Scene& scene)
{
    for (const AnimationTrack& track : animation.tracks) {
        const std::vector<float> v = evaluate(track, timeS);
        const std::string& t = track.target;
        const glm::vec3 v3 = v.size() == 3 ? glm::vec3(v[0], v[1], v[2]) : glm::vec3(0.0f);
        if (t == "/camera/position") {
            config.camera.position = v3;
        } else if (t == "/camera/target") {
            config.camera.target = v3;
        } else if (t == "/camera/fov_y_deg") {
            config.camera.fovYDeg = std::clamp(v[0], 1e-3f, 179.0f);
        } else if (t.rfind("/lights/", 0) == 0) {
            const size_t slash = t.find('/', 8);
            LightConfig& lc = config.lights.at(std::stoul(t.substr(8, slash - 8)));
            const std::string field = t.substr(slash + 1);
            if (field == "position") lc.light.position = v3;
            if (field == "target") lc.target = v3;
            if (field == "intensity") lc.light.intensity = std::max(v[0], 0.0f);
            if (field == "color") lc.light.color = glm::max(v3, glm::vec3(0.0f));
        } else if (t.rfind("node:", 0) == 0) {
            const size_t slash = t.rfind('/');
            const std::string name = t.substr(5, slash - 5);
            const std::string field = t.substr(slash + 1);
            for (uint32_t n = 0; n < scene.graph.size(); ++n) {
                if (scene.graph.node(n).name != name) continue;
                glm::vec3 scale(1.0f), translation(0.0f), skew(0.0f);
                glm::quat rotation(1.0f, 0.0f, 0.0f, 0.0f);
                glm::vec4 perspective(0.0f, 0.0f, 0.0f, 1.0f);
                glm::decompose(scene.graph.local(n), scale, rotation, translation, skew, perspective);
                if (field == "translation") translation = v3;
                if (field == "scale") scale = v3;
                if (field == "rotation_deg") rotation = glm::quat_cast(glm::eulerAngleXYZ(glm::radians(v3.x), glm::radians(v3.y), glm::radians(v3.z)));
                scene.graph.setLocal(n, composeTrs(translation, rotation, scale));
            }
        }
    }
    // A light aimed at a target keeps aiming at it as either moves.
    for (LightConfig& lc : config.lights) {
        if (lc.target && glm::length(*lc.target - lc.light.position) > 0.0f) {
            lc.light.direction = glm::normalize(*lc.target - lc.light.position);
        }
    }
}

} // namespace penumbra::config
