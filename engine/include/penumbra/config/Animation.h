#pragma once
// Animation tracks: keyframed values over time, interpolated, each aimed at one
// animatable value of a config or a scene node. One config can script a whole run:
// frame i of `frames` is shown at time i / fps.
#include <cstdint>
#include <string>
#include <vector>

namespace penumbra::scene {
class Scene;
}

namespace penumbra::config {

struct RenderConfig;  // config/Config.h

enum class Interpolation {
    Step,    // hold each key until the next
    Linear,  // straight lines between keys
    Smooth,  // Catmull-Rom through the keys (end tangents one-sided)
};

struct Keyframe {
    float timeS = 0.0f;
    std::vector<float> value;
};

struct AnimationTrack {
    // "/camera/position", "/camera/target", "/camera/fov_y_deg",
    // "/lights/<i>/position", "/lights/<i>/target", "/lights/<i>/intensity", "/lights/<i>/color",
    // "node:<name>/translation", "node:<name>/rotation_deg" (XYZ Euler), "node:<name>/scale".
    std::string target;
    Interpolation interpolation = Interpolation::Linear;
    std::vector<Keyframe> keys;  // strictly increasing times, all values the same size
};

// What an animation may ask for, checked where "animation" is read: fps within [kMinFps,
// kMaxFps] (1e-46 became 0 as a float, and frame / fps NaN), key times finite in [0,
// kMaxKeyTimeS] and strictly increasing as floats, and the last key reached within
// kMaxFrames frames (its time × fps), the most a config's "frames" asks for.
inline constexpr double kMinFps = 1e-3;
inline constexpr double kMaxFps = 1e4;
inline constexpr double kMaxKeyTimeS = 1e9;
inline constexpr uint32_t kMaxFrames = 1000000;

struct Animation {
    float fps = 30.0f;
    std::vector<AnimationTrack> tracks;
    bool empty() const { return tracks.empty(); }
};

// The frames that show times 0 ... durationS at `fps` (frame f at f / fps), at most
// kMaxFrames: what the viewer's Save writes so that `penumbra render` plays it through.
uint32_t framesToPlay(float durationS, float fps);

// The track's value at `timeS`; before the first key (or at a NaN time) the first value,
// after the last key the last value; finite for every time, each component within a
// float's range.
std::vector<float> evaluate(const AnimationTrack& track, float timeS);

// Moves camera, lights and scene nodes to time `timeS` of the config's animation.
// `config` holds the animated values afterwards; nodes are set in `scene`'s graph (call
// scene.updateTransforms() after). config/Run.h's PreparedRun::poseAt does both, from the
// config's rest state.
void applyAnimation(const Animation& animation, float timeS, RenderConfig& config, scene::Scene& scene);

} // namespace penumbra::config
