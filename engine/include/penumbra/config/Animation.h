#pragma once
// Animation tracks: keyframed values over time, interpolated, each aimed at one
// animatable value of a config or a scene node. One config can script a whole run:
// frame i of `frames` is shown at time i / fps.
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

struct Animation {
    float fps = 30.0f;
    std::vector<AnimationTrack> tracks;
    bool empty() const { return tracks.empty(); }
};

// The track's value at `timeS`; before the first key the first value, after the last
// key the last value.
std::vector<float> evaluate(const AnimationTrack& track, float timeS);

// Moves camera, lights and scene nodes to time `timeS` of the config's animation.
// `config` holds the animated values afterwards; nodes are set in `scene`'s graph (call
// scene.updateTransforms() after). config/Run.h's PreparedRun::poseAt does both, from the
// config's rest state.
void applyAnimation(const Animation& animation, float timeS, RenderConfig& config, scene::Scene& scene);

} // namespace penumbra::config
