#include "scene/gltf/Animations.h"

#include "penumbra/core/ShortText.h"

#include "scene/gltf/Accessors.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <optional>

namespace penumbra::scene::gltf {
namespace {

// Keys a file may hold in all (times and values alike): far beyond any hand-made or
// exported clip, short of what would exhaust memory before a check.
constexpr size_t kMaxKeyFloats = size_t(1) << 26;

std::optional<ChannelPath> pathOf(const std::string& path)
{
    if (path == "translation") return ChannelPath::Translation;
    if (path == "rotation") return ChannelPath::Rotation;
    if (path == "scale") return ChannelPath::Scale;
    return std::nullopt;
}

NodeRestPose restPose(const tinygltf::Node& node, uint32_t graphNode)
{
    NodeRestPose rest;
    rest.node = graphNode;
    if (node.translation.size() == 3) rest.translation = glm::vec3(node.translation[0], node.translation[1], node.translation[2]);
    if (node.rotation.size() == 4) {
        const glm::quat q(float(node.rotation[3]), float(node.rotation[0]), float(node.rotation[1]), float(node.rotation[2]));
        rest.rotation = glm::normalize(q);  // the node's own check refused a zero quaternion
    }
    if (node.scale.size() == 3) rest.scale = glm::vec3(node.scale[0], node.scale[1], node.scale[2]);
    return rest;
}

// The channel, or why it cannot play.
std::optional<NodeChannel> loadChannel(const Document& doc, const NodeMap& nodes, const tinygltf::Animation& animation,
                                       size_t a, size_t c, size_t& floatsLeft, std::string& why)
{
    const tinygltf::AnimationChannel& channel = animation.channels[c];
    const std::string element = fmt::format("/animations/{}/channels/{}", a, c);
    const std::optional<ChannelPath> path = pathOf(channel.target_path);
    if (!path) {
        why = channel.target_path == "weights" ? "morph target weights are not played (morph targets are ignored)"
                                               : fmt::format("target path {} is not translation, rotation or scale",
                                                             core::shortJson(channel.target_path));
        return std::nullopt;
    }
    if (channel.target_node < 0 || size_t(channel.target_node) >= doc.model.nodes.size()) {
        why = fmt::format("target node {} does not exist", channel.target_node);
        return std::nullopt;
    }
    const int graphNode = nodes.graphNode[size_t(channel.target_node)];
    if (graphNode < 0) {
        why = fmt::format("target node {} is not in the loaded scene", channel.target_node);
        return std::nullopt;
    }
    if (!doc.model.nodes[size_t(channel.target_node)].matrix.empty()) {
        why = fmt::format("target node {} is given by a matrix, which glTF does not let an animation move", channel.target_node);
        return std::nullopt;
    }
    if (channel.sampler < 0 || size_t(channel.sampler) >= animation.samplers.size()) {
        why = fmt::format("sampler {} does not exist (the animation has {})", channel.sampler, animation.samplers.size());
        return std::nullopt;
    }
    const tinygltf::AnimationSampler& sampler = animation.samplers[size_t(channel.sampler)];
    const std::string samplerElement = fmt::format("/animations/{}/samplers/{}", a, channel.sampler);
    NodeChannel out;
    out.node = uint32_t(graphNode);
    out.path = *path;
    if (sampler.interpolation == "STEP") out.interpolation = KeyInterpolation::Step;
    else if (sampler.interpolation == "CUBICSPLINE") out.interpolation = KeyInterpolation::CubicSpline;
    else if (sampler.interpolation.empty() || sampler.interpolation == "LINEAR") out.interpolation = KeyInterpolation::Linear;
    else {
        why = fmt::format("{}: interpolation {} is not STEP, LINEAR or CUBICSPLINE", samplerElement,
                          core::shortJson(sampler.interpolation));
        return std::nullopt;
    }
    const CountLimit limit{floatsLeft, fmt::format("animation keys left of the limit of {} floats per file", kMaxKeyFloats)};
    out.times = readAttribute(doc, sampler.input, samplerElement + "/input", AttributeKind::KeyTimes, limit);
    floatsLeft -= std::min(floatsLeft, out.times.size());
    const CountLimit valueLimit{floatsLeft / 4, limit.what};
    out.values = readAttribute(doc, sampler.output, samplerElement + "/output",
                               *path == ChannelPath::Rotation ? AttributeKind::KeyRotation : AttributeKind::KeyVec3, valueLimit);
    floatsLeft -= std::min(floatsLeft, out.values.size());

    const size_t keys = out.times.size();
    if (keys == 0) {
        why = fmt::format("{}: no keys", samplerElement);
        return std::nullopt;
    }
    for (size_t k = 0; k < keys; ++k) {
        if (!std::isfinite(out.times[k]) || (k > 0 && !(out.times[k] > out.times[k - 1]))) {
            why = fmt::format("{}: key times must be finite and increase strictly: key {} is {} after {}", samplerElement, k,
                              out.times[k], k > 0 ? out.times[k - 1] : 0.0f);
            return std::nullopt;
        }
    }
    const size_t perKey = size_t(out.components()) * (out.interpolation == KeyInterpolation::CubicSpline ? 3 : 1);
    if (out.values.size() != keys * perKey) {
        why = fmt::format("{}: {} output values for {} keys, expected {}", samplerElement, out.values.size() / out.components(),
                          keys, keys * perKey / out.components());
        return std::nullopt;
    }
    if (!std::all_of(out.values.begin(), out.values.end(), [](float v) { return std::isfinite(v); })) {
        why = fmt::format("{}: an output value is not finite", samplerElement);
        return std::nullopt;
    }
    return out;
}

} // namespace

std::vector<NodeAnimation> loadAnimations(const Document& doc, const NodeMap& nodes)
{
    std::vector<NodeAnimation> clips;
    size_t floatsLeft = kMaxKeyFloats;
    for (size_t a = 0; a < doc.model.animations.size(); ++a) {
        const tinygltf::Animation& animation = doc.model.animations[a];
        NodeAnimation clip;
        clip.name = animation.name.empty() ? fmt::format("animation{}", a) : animation.name;
        for (size_t c = 0; c < animation.channels.size(); ++c) {
            std::string why;
            std::optional<NodeChannel> channel = loadChannel(doc, nodes, animation, a, c, floatsLeft, why);
            if (!channel) {
                doc.warn(fmt::format("/animations/{}/channels/{}", a, c), fmt::format("{}; the channel is left out", why));
                continue;
            }
            const uint32_t node = channel->node;
            if (std::none_of(clip.rest.begin(), clip.rest.end(), [&](const NodeRestPose& r) { return r.node == node; })) {
                clip.rest.push_back(restPose(doc.model.nodes[size_t(doc.model.animations[a].channels[c].target_node)], node));
            }
            clip.channels.push_back(std::move(*channel));
        }
        if (clip.channels.empty()) {
            doc.warn(fmt::format("/animations/{}", a), "has no channel that can play; left out");
            continue;
        }
        clips.push_back(std::move(clip));
    }
    return clips;
}

} // namespace penumbra::scene::gltf
