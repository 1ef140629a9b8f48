#define GLM_ENABLE_EXPERIMENTAL  // glm/gtx: euler angles and matrix decomposition for node tracks
#include "penumbra/config/Animation.h"

#include "config/AnimationReader.h"
#include "penumbra/config/Config.h"
#include "penumbra/core/ShortText.h"

#include <fmt/format.h>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtx/euler_angles.hpp>
#include <glm/gtx/matrix_decompose.hpp>

#include <algorithm>
#include <cassert>
#include <cctype>
#include <cmath>
#include <limits>
#include <map>

using nlohmann::json;

namespace penumbra::config {
namespace {

// How many numbers an animation target takes, or 0 when it cannot be animated: `why`
// then says why (the message after the track's JSON path).
size_t targetSize(const std::string& target, const std::vector<LightConfig>& lights, std::string& why)
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
        if (!digits || std::stoul(index) >= lights.size()) {
            why = fmt::format("unknown target \"{}\": light index '{}' is not one of the {} configured lights",
                              core::shortText(target), core::shortText(index), lights.size());
            return 0;
        }
        static const std::vector<std::pair<std::string, size_t>> fields = {
            {"position", 3}, {"target", 3}, {"direction", 3}, {"intensity", 1}, {"color", 3}};
        const auto known = std::find_if(fields.begin(), fields.end(), [&](const auto& f) { return f.first == field; });
        if (known == fields.end()) {
            why = fmt::format("unknown target \"{}\": a light's animatable values are position, target, direction, "
                              "intensity and color, got '{}'",
                              core::shortText(target), core::shortText(field));
            return 0;
        }
        // Values a light of its kind does not have would be set and never used.
        const LightConfig& lc = lights[std::stoul(index)];
        const scene::LightType type = lc.light.type;
        if (type == scene::LightType::Directional && (field == "position" || field == "target")) {
            why = fmt::format("\"{}\" cannot be animated: a directional light has no position, it shines along its "
                              "direction; animate /lights/{}/direction",
                              target, index);
        } else if (type == scene::LightType::Point && (field == "target" || field == "direction")) {
            why = fmt::format("\"{}\" cannot be animated: a point light shines every way, it has no direction", target);
        } else if (field == "direction" && lc.target) {
            why = fmt::format("\"{}\" cannot be animated: light {} is aimed at its \"target\", which sets its direction; "
                              "animate /lights/{}/target, or give the light a \"direction\"",
                              target, index, index);
        }
        return why.empty() ? known->second : 0;
    }
    if (target.rfind("node:", 0) == 0) {
        const size_t slash = target.rfind('/');
        const std::string field = slash == std::string::npos ? "" : target.substr(slash + 1);
        if (slash == std::string::npos || slash <= 5) {
            why = "expected node:<name>/translation, node:<name>/rotation_deg or node:<name>/scale";
            return 0;
        }
        if (field == "translation" || field == "rotation_deg" || field == "scale") return 3;
        why = fmt::format("a node's animatable values are translation, rotation_deg and scale, got '{}'",
                          core::shortText(field));
        return 0;
    }
    why = "expected /camera/..., /lights/<i>/... or node:<name>/...";
    return 0;
}

glm::mat4 composeTrs(const glm::vec3& t, const glm::quat& r, const glm::vec3& s)
{
    return glm::translate(glm::mat4(1.0f), t) * glm::mat4_cast(r) * glm::scale(glm::mat4(1.0f), s);
}

bool isDirectionTrack(const std::string& target)
{
    return target.rfind("/lights/", 0) == 0 && target.ends_with("/direction");
}

// A direction track's key: non-zero, and (unless the track steps) not opposite to the key
// before it, which would make the interpolated direction pass through zero between them.
void checkDirectionKey(const AnimationTrack& track, const glm::vec3& value, const ObjectReader& key, const std::string& at)
{
    if (!(glm::length(value) > 0.0f)) key.fail(at, "a direction must be non-zero");
    if (track.keys.empty() || track.interpolation == Interpolation::Step) return;
    const std::vector<float>& p = track.keys.back().value;
    if (glm::dot(glm::normalize(glm::vec3(p[0], p[1], p[2])), glm::normalize(value)) < -0.9999f) {
        key.fail(at, fmt::format("points opposite to key {}: the direction would pass through zero between them; "
                                 "add a key in between",
                                 track.keys.size() - 1));
    }
}

// A rect light's width axis, kept in its emitting plane as its direction turns: the
// configured axis projected onto the plane, or any axis in it when they are parallel.
glm::vec3 tangentAcross(glm::vec3 tangent, const glm::vec3& direction)
{
    tangent -= glm::dot(tangent, direction) * direction;
    if (glm::length(tangent) > 1e-4f) return glm::normalize(tangent);
    const glm::vec3 axis = std::abs(direction.y) < 0.9f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0);
    return glm::normalize(axis - glm::dot(axis, direction) * direction);
}

} // namespace

Animation readAnimation(ObjectReader& parent, const std::vector<LightConfig>& lights, bool playsSceneAnimation)
{
    Animation animation;
    const json* v = parent.find("animation");
    if (!v) return animation;
    ObjectReader r(*v, parent.locator(), "/animation");
    animation.fps = float(r.number("fps", animation.fps, kMinFps, kMaxFps));
    const json* found = r.find("tracks");
    static const json kNoTracks = json::array();
    const json& tracks = found ? *found : kNoTracks;
    if (!tracks.is_array()) r.fail("/animation/tracks", "must be an array of tracks");
    // Without tracks, fps is the frame rate of the glTF animation the scene plays; with
    // neither, the object would animate nothing, which is a mistake more often than not.
    if (tracks.empty() && !playsSceneAnimation) {
        r.fail("/animation", "has no tracks and /scene plays no glTF animation, so it animates nothing: give "
                             "\"tracks\", or remove \"animation\"");
    }
    // Per light ("/lights/<i>"), the first track that aims it: at a target, or along a direction.
    std::map<std::string, size_t> aimingTrack;
    for (size_t i = 0; i < tracks.size(); ++i) {
        const std::string at = fmt::format("/animation/tracks/{}", i);
        ObjectReader t(tracks[i], parent.locator(), at);
        AnimationTrack track;
        const json& target = t.require("target");
        if (!target.is_string()) t.fail(at + "/target", "must be a string");
        track.target = target.get<std::string>();
        std::string why;
        const size_t size = targetSize(track.target, lights, why);
        if (size == 0) t.fail(at + "/target", why);
        const bool lightTarget = track.target.rfind("/lights/", 0) == 0 && track.target.ends_with("/target");
        if (lightTarget || isDirectionTrack(track.target)) {
            const std::string light = track.target.substr(0, track.target.rfind('/'));
            const size_t first = aimingTrack.emplace(light, i).first->second;
            const std::string& other = tracks[first]["target"].get_ref<const std::string&>();
            if (other != track.target) {
                t.fail(at + "/target", fmt::format("\"{}\" cannot be animated: /animation/tracks/{} animates \"{}\"; a "
                                                   "light follows either a target or a direction",
                                                   core::shortText(track.target), first, core::shortText(other)));
            }
        }
        const std::string interp = t.choice("interpolation", "linear", {"step", "linear", "smooth"});
        track.interpolation = interp == "step" ? Interpolation::Step
                              : interp == "smooth" ? Interpolation::Smooth : Interpolation::Linear;
        const json& keys = t.require("keys");
        if (!keys.is_array() || keys.empty()) t.fail(at + "/keys", "must be a non-empty array of {\"t\": seconds, \"value\": ...}");
        for (size_t k = 0; k < keys.size(); ++k) {
            const std::string kat = fmt::format("{}/keys/{}", at, k);
            ObjectReader key(keys[k], parent.locator(), kat);
            Keyframe frame;
            frame.timeS = float(key.number("t", 0.0, 0.0, kMaxKeyTimeS));
            if (!key.find("t")) key.fail(kat + "/t", "is required but missing");
            if (const double frames = double(frame.timeS) * animation.fps; frames > kMaxFrames) {
                key.fail(kat + "/t", fmt::format("{} s at {} fps is frame {:.0f}; an animation ends within {} frames "
                                                 "(lower the time or /animation/fps)",
                                                 frame.timeS, animation.fps, frames, kMaxFrames));
            }
            const json& value = key.require("value");
            if (size == 1 && value.is_number()) {
                frame.value = {float(key.checkNumber(value, kat + "/value", -3e38, 3e38, false))};
            } else if (size == 3) {
                const glm::vec3 x = key.checkVec3(value, kat + "/value");
                if (isDirectionTrack(track.target)) checkDirectionKey(track, x, key, kat + "/value");
                frame.value = {x.x, x.y, x.z};
            } else {
                key.fail(kat + "/value", fmt::format("must be {} for {}", size == 1 ? "a number" : "an array of 3 numbers",
                                                     core::shortText(track.target)));
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

uint32_t framesToPlay(float durationS, float fps)
{
    const double frames = std::ceil(double(durationS) * double(fps)) + 1.0;
    if (!(frames >= 1.0)) return 1u;  // a NaN or negative duration: the rest pose
    return uint32_t(std::min(frames, double(kMaxFrames)));
}

std::vector<float> evaluate(const AnimationTrack& track, float timeS)
{
    assert(!track.keys.empty());  // validation guarantees at least one key
    const std::vector<Keyframe>& k = track.keys;
    // Written so that a NaN time takes the first key.
    if (k.size() == 1 || !(timeS > k.front().timeS)) return k.front().value;
    if (timeS >= k.back().timeS) return k.back().value;
    // First key after timeS: keys are strictly increasing (validated), so 1 <= i < size.
    const size_t i = static_cast<size_t>(
        std::upper_bound(k.begin(), k.end(), timeS, [](float t, const Keyframe& key) { return t < key.timeS; }) -
        k.begin());
    const Keyframe& a = k[i - 1];
    const Keyframe& b = k[i];
    if (track.interpolation == Interpolation::Step) return a.value;
    // In double: values reach a float's range, and their differences beyond it. Strictly
    // increasing times make the span positive, so u is finite, and within [0, 1].
    const double span = double(b.timeS) - double(a.timeS);
    const double u = std::clamp((double(timeS) - double(a.timeS)) / span, 0.0, 1.0);
    const auto toFloat = [](double x) {
        constexpr double kMax = std::numeric_limits<float>::max();
        return float(std::clamp(x, -kMax, kMax));
    };
    std::vector<float> out(a.value.size());
    if (track.interpolation == Interpolation::Linear) {
        for (size_t c = 0; c < out.size(); ++c) out[c] = toFloat(a.value[c] + u * (double(b.value[c]) - a.value[c]));
        return out;
    }
    // Catmull-Rom (uniform in parameter, tangents scaled to the span lengths so that
    // uneven key spacing does not overshoot); the missing neighbour at either end
    // repeats the end key, giving a one-sided tangent. Each tangent's span holds the
    // key span, so it is positive too.
    const Keyframe& p0 = i >= 2 ? k[i - 2] : a;
    const Keyframe& p3 = i + 1 < k.size() ? k[i + 1] : b;
    const double spanA = double(b.timeS) - double(p0.timeS);
    const double spanB = double(p3.timeS) - double(a.timeS);
    const double u2 = u * u, u3 = u2 * u;
    for (size_t c = 0; c < out.size(); ++c) {
        const double m0 = (double(b.value[c]) - p0.value[c]) / spanA * span;
        const double m1 = (double(p3.value[c]) - a.value[c]) / spanB * span;
        out[c] = toFloat((2 * u3 - 3 * u2 + 1) * a.value[c] + (u3 - 2 * u2 + u) * m0 + (-2 * u3 + 3 * u2) * b.value[c] +
                         (u3 - u2) * m1);
    }
    return out;
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
            // Keys are non-zero and no two neighbours opposite (checkDirectionKey); a
            // smooth curve that still comes (nearly) through zero keeps the direction the
            // light had before this track rather than flip.
            if (field == "direction" && glm::dot(v3, v3) > 1e-30f) lc.light.direction = glm::normalize(v3);
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
        if (lc.light.type == scene::LightType::Rect) lc.light.tangent = tangentAcross(lc.light.tangent, lc.light.direction);
    }
}

} // namespace penumbra::config
