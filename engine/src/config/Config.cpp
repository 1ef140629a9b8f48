#include "penumbra/config/Config.h"

#include "penumbra/core/Error.h"

#include <fmt/format.h>
#include <glm/gtc/constants.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>

using nlohmann::json;
namespace fs = std::filesystem;

namespace penumbra::config {
namespace {

size_t editDistance(const std::string& a, const std::string& b)
{
    std::vector<size_t> row(b.size() + 1);
    for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
    for (size_t i = 1; i <= a.size(); ++i) {
        size_t diagonal = row[0];
        row[0] = i;
        for (size_t j = 1; j <= b.size(); ++j) {
            const size_t up = row[j];
            row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
            diagonal = up;
        }
    }
    return row[b.size()];
}

// One JSON object being read: remembers which keys were consumed so that unknown keys
// (typos) are errors, with a suggestion when a known key is close.
class ObjectReader {
public:
    ObjectReader(const json& value, std::string file, std::string pointer)
        : value_(value), file_(std::move(file)), pointer_(std::move(pointer))
    {
        if (!value_.is_object()) {
            fail(pointer_, fmt::format("must be an object, got {}", value_.type_name()));
        }
    }

    [[noreturn]] void fail(const std::string& pointer, const std::string& what) const
    {
        throw ConfigError(fmt::format("{}: {}: {}", file_, pointer.empty() ? "/" : pointer, what));
    }

    std::string path(const std::string& key) const { return pointer_ + "/" + key; }

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
        if (!v) return fallback;
        if (!v->is_number()) fail(path(key), fmt::format("must be a number, got {}", v->type_name()));
        const double x = v->get<double>();
        const bool below = loOpen ? x <= lo : x < lo;
        if (!std::isfinite(x) || below || x > hi) {
            fail(path(key), fmt::format("must be in {}{}, {}], got {}", loOpen ? "(" : "[", lo, hi, x));
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
        if (!v) return fallback;
        if (!v->is_array() || v->size() != 3 ||
            !std::all_of(v->begin(), v->end(), [](const json& e) { return e.is_number(); })) {
            fail(path(key), fmt::format("must be an array of 3 numbers, got {}", v->dump()));
        }
        glm::vec3 out;
        for (int i = 0; i < 3; ++i) {
            out[i] = (*v)[i].get<float>();
            if (!std::isfinite(out[i])) fail(path(key), "must be finite");
        }
        return out;
    }

    std::string choice(const std::string& key, const std::string& fallback, const std::vector<std::string>& allowed)
    {
        const json* v = find(key);
        if (!v) return fallback;
        if (!v->is_string()) fail(path(key), fmt::format("must be a string, got {}", v->type_name()));
        const std::string s = v->get<std::string>();
        if (std::find(allowed.begin(), allowed.end(), s) == allowed.end()) {
            fail(path(key), fmt::format("must be one of {}, got \"{}\"", fmt::join(allowed, ", "), s));
        }
        return s;
    }

    // Unknown keys are errors: a typo must not silently fall back to a default.
    void finish() const
    {
        for (auto it = value_.begin(); it != value_.end(); ++it) {
            if (known_.count(it.key())) continue;
            std::string best;
            size_t bestDistance = 3;
            for (const std::string& k : known_) {
                const size_t d = editDistance(it.key(), k);
                if (d < bestDistance) {
                    bestDistance = d;
                    best = k;
                }
            }
            std::vector<std::string> keys(known_.begin(), known_.end());
            fail(path(it.key()), best.empty()
                                     ? fmt::format("unknown key (expected one of: {})", fmt::join(keys, ", "))
                                     : fmt::format("unknown key; did you mean \"{}\"?", best));
        }
    }

    const std::string& file() const { return file_; }

private:
    const json& value_;
    std::string file_;
    std::string pointer_;
    std::set<std::string> known_;
};

SceneSource readScene(ObjectReader& parent)
{
    SceneSource source;
    const json* v = parent.find("scene");
    if (!v) return source;
    ObjectReader r(*v, parent.file(), "/scene");
    source.generator = r.choice("generator", source.generator, {"box-grid"});
    scene::BoxGridParams& p = source.boxGrid;
    p.columns = r.integer("columns", p.columns, 1, 64);
    p.rows = r.integer("rows", p.rows, 1, 64);
    p.boxSize = float(r.number("box_size", p.boxSize, 0.0, 1e6, true));
    p.spacing = float(r.number("spacing", p.spacing, 0.0, 1e6, true));
    p.minHeight = float(r.number("min_height", p.minHeight, 0.0, 1e6, true));
    p.maxHeight = float(r.number("max_height", p.maxHeight, 0.0, 1e6, true));
    if (p.maxHeight < p.minHeight) r.fail("/scene/max_height", fmt::format("must be >= min_height ({}), got {}", p.minHeight, p.maxHeight));
    p.sphereRadius = float(r.number("sphere_radius", p.sphereRadius, 0.0, 1e6, true));
    p.sphereSegments = r.integer("sphere_segments", p.sphereSegments, 3, 1024);
    p.planeSize = float(r.number("plane_size", p.planeSize, 0.0, 1e7, true));
    p.seed = r.integer("seed", p.seed, 0, 0xffffffffu);
    r.finish();
    return source;
}

scene::Camera readCamera(ObjectReader& parent)
{
    scene::Camera camera;
    ObjectReader r(parent.require("camera"), parent.file(), "/camera");
    camera.position = r.vec3("position", camera.position, true);
    camera.target = r.vec3("target", camera.target, true);
    camera.up = r.vec3("up", camera.up);
    camera.fovYDeg = float(r.number("fov_y_deg", camera.fovYDeg, 0.0, 179.0, true));
    camera.nearWorld = float(r.number("near", camera.nearWorld, 0.0, 1e9, true));
    r.finish();
    const glm::vec3 forward = camera.target - camera.position;
    if (glm::length(forward) <= 0.0f) r.fail("/camera/target", "must differ from /camera/position");
    if (glm::length(camera.up) <= 0.0f || glm::length(glm::cross(glm::normalize(forward), glm::normalize(camera.up))) < 1e-4f) {
        r.fail("/camera/up", "must be non-zero and not parallel to the view direction");
    }
    return camera;
}

ShadowSettings readShadow(const json* v, const std::string& file, const std::string& pointer)
{
    ShadowSettings s;
    if (!v) return s;
    ObjectReader r(*v, file, pointer);
    s.technique = r.choice("technique", s.technique, {"hard"});
    s.resolution = r.integer("resolution", s.resolution, 16, 16384);
    s.depthBiasConstant = float(r.number("depth_bias", s.depthBiasConstant, 0.0, 1e6));
    s.depthBiasSlope = float(r.number("slope_bias", s.depthBiasSlope, 0.0, 1e3));
    s.depthBiasClamp = float(r.number("bias_clamp", s.depthBiasClamp, 0.0, 1.0));
    r.finish();
    return s;
}

LightConfig readLight(const json& v, const std::string& file, const std::string& pointer)
{
    LightConfig lc;
    ObjectReader r(v, file, pointer);
    r.choice("type", "spot", {"spot"});
    scene::Light& l = lc.light;
    l.position = r.vec3("position", l.position, true);
    const glm::vec3 target = r.vec3("target", l.position + l.direction, true);
    if (glm::length(target - l.position) <= 0.0f) r.fail(pointer + "/target", "must differ from position");
    l.direction = glm::normalize(target - l.position);
    l.outerConeDeg = float(r.number("outer_cone_deg", l.outerConeDeg, 0.0, 89.0, true));
    l.innerConeDeg = float(r.number("inner_cone_deg", std::min(l.innerConeDeg, l.outerConeDeg), 0.0, 89.0));
    if (l.innerConeDeg > l.outerConeDeg) {
        r.fail(pointer + "/inner_cone_deg", fmt::format("must be <= outer_cone_deg ({}), got {}", l.outerConeDeg, l.innerConeDeg));
    }
    l.intensity = float(r.number("intensity", l.intensity, 0.0, 1e12));
    l.color = r.vec3("color", l.color);
    if (glm::any(glm::lessThan(l.color, glm::vec3(0.0f)))) r.fail(pointer + "/color", "components must be >= 0");
    lc.shadow = readShadow(r.find("shadow"), file, pointer + "/shadow");
    r.finish();
    return lc;
}

} // namespace

RenderConfig parseConfig(const json& document, const fs::path& file)
{
    RenderConfig config;
    config.file = file;
    ObjectReader r(document, file.string(), "");
    config.scene = readScene(r);
    config.camera = readCamera(r);
    const json& lights = r.require("lights");
    if (!lights.is_array() || lights.empty()) r.fail("/lights", "must be a non-empty array of lights");
    if (lights.size() > kMaxLights) r.fail("/lights", fmt::format("at most {} lights, got {}", kMaxLights, lights.size()));
    for (size_t i = 0; i < lights.size(); ++i) {
        config.lights.push_back(readLight(lights[i], file.string(), fmt::format("/lights/{}", i)));
    }
    if (const json* out = r.find("output")) {
        ObjectReader o(*out, file.string(), "/output");
        config.width = o.integer("width", config.width, 1, 16384);
        config.height = o.integer("height", config.height, 1, 16384);
        o.finish();
    }
    config.frames = r.integer("frames", config.frames, 1, 100000);
    r.finish();
    return config;
}

RenderConfig loadConfig(const fs::path& file)
{
    std::error_code ec;
    if (!fs::exists(file, ec)) throw ConfigError(fmt::format("{}: config file not found", file.string()));
    if (fs::is_directory(file, ec)) throw ConfigError(fmt::format("{}: is a directory, expected a JSON config file", file.string()));
    std::ifstream in(file, std::ios::binary);
    if (!in) throw ConfigError(fmt::format("{}: cannot open config file for reading", file.string()));
    json document;
    try {
        document = json::parse(in);
    } catch (const json::parse_error& e) {
        // nlohmann's message carries line and column: "parse error at line 3, column 5: ...".
        std::string what = e.what();
        if (auto pos = what.find("parse error"); pos != std::string::npos) what = what.substr(pos);
        throw ConfigError(fmt::format("{}: malformed JSON: {}", file.string(), what));
    }
    return parseConfig(document, file);
}

scene::Scene buildScene(const SceneSource& source)
{
    // Only "box-grid" passes validation today; glTF and the other generators arrive with
    // the scenes issue.
    return scene::generateBoxGrid(source.boxGrid);
}

} // namespace penumbra::config
