#pragma once
// Keyframed node transforms as glTF animations hold them: a clip of channels, each moving
// one node's translation, rotation or scale with STEP, LINEAR (rotations: shortest-arc
// slerp) or CUBICSPLINE (Hermite, tangents scaled by the key interval) interpolation. The
// glTF loader reads a file's clips into Scene::animations; a config plays one of them
// ("scene": {"gltf": ..., "animation": "name"}, or per part: config::poseScene).
#include "penumbra/scene/SceneGraph.h"

#include <glm/glm.hpp>
#include <glm/gtc/quaternion.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace penumbra::scene {

enum class ChannelPath { Translation, Rotation, Scale };
enum class KeyInterpolation { Step, Linear, CubicSpline };

struct NodeChannel {
    uint32_t node = 0;  // scene graph node
    ChannelPath path = ChannelPath::Translation;
    KeyInterpolation interpolation = KeyInterpolation::Linear;
    std::vector<float> times;  // seconds, finite, strictly increasing, at least one
    // Per key 3 floats (translation, scale) or 4 (rotation x, y, z, w); CubicSpline holds
    // in-tangent, value and out-tangent per key, as glTF does.
    std::vector<float> values;

    uint32_t components() const { return path == ChannelPath::Rotation ? 4u : 3u; }
};

// A node's transform at rest, in parts: a channel replaces one part.
struct NodeRestPose {
    uint32_t node = 0;
    glm::vec3 translation{0.0f};
    glm::quat rotation{1.0f, 0.0f, 0.0f, 0.0f};
    glm::vec3 scale{1.0f};
};

struct NodeAnimation {
    std::string name;
    std::vector<NodeChannel> channels;
    std::vector<NodeRestPose> rest;  // every node a channel moves
    // The last key of any channel (0 without channels).
    float duration() const;
};

// The channel's value at `timeS`: xyz (translation, scale) or xyzw (a unit rotation).
// Before the first key the first value, after the last key the last.
glm::vec4 sample(const NodeChannel& channel, float timeS);

// Poses every node the animation moves: its rest pose, with the parts its channels give
// at `timeS` (local = T · R · S). Call graph.update() (Scene::updateTransforms) after.
void applyNodeAnimation(const NodeAnimation& animation, float timeS, SceneGraph& graph);

} // namespace penumbra::scene
