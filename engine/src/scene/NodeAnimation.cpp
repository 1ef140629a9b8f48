#include "penumbra/scene/NodeAnimation.h"

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>

namespace penumbra::scene {
namespace {

glm::vec4 valueAt(const NodeChannel& c, size_t key, size_t part)
{
    // CubicSpline: [in-tangent, value, out-tangent] per key; part 0, 1, 2.
    const size_t n = c.components();
    const size_t stride = c.interpolation == KeyInterpolation::CubicSpline ? 3 * n : n;
    const size_t at = key * stride + (c.interpolation == KeyInterpolation::CubicSpline ? part * n : 0);
    glm::vec4 v(0.0f);
    for (size_t i = 0; i < n; ++i) v[int(i)] = c.values[at + i];
    return v;
}

glm::vec4 normalizedRotation(glm::vec4 q)
{
    const float length = glm::length(q);
    // A zero quaternion (a broken file's key) is no rotation.
    return length > 0.0f && std::isfinite(length) ? q / length : glm::vec4(0.0f, 0.0f, 0.0f, 1.0f);
}

} // namespace

float NodeAnimation::duration() const
{
    float end = 0.0f;
    for (const NodeChannel& c : channels) {
        if (!c.times.empty()) end = std::max(end, c.times.back());
    }
    return end;
}

glm::vec4 sample(const NodeChannel& c, float timeS)
{
    const bool rotation = c.path == ChannelPath::Rotation;
    const std::vector<float>& t = c.times;
    glm::vec4 out;
    if (t.size() == 1 || !(timeS > t.front())) {
        out = valueAt(c, 0, 1);
    } else if (timeS >= t.back()) {
        out = valueAt(c, t.size() - 1, 1);
    } else {
        // The key interval [t[i-1], t[i]) holding timeS; times strictly increase, so the
        // interval is positive and u is finite.
        const size_t i = size_t(std::upper_bound(t.begin(), t.end(), timeS) - t.begin());
        const float span = t[i] - t[i - 1];
        const float u = std::clamp((timeS - t[i - 1]) / span, 0.0f, 1.0f);
        const glm::vec4 a = valueAt(c, i - 1, 1), b = valueAt(c, i, 1);
        switch (c.interpolation) {
        case KeyInterpolation::Step: out = a; break;
        case KeyInterpolation::Linear:
            if (rotation) {
                const glm::quat qa(a.w, a.x, a.y, a.z), qb(b.w, b.x, b.y, b.z);
                // glm::slerp takes the shorter arc (it flips qb when the dot is negative).
                const glm::quat q = glm::slerp(glm::normalize(qa), glm::normalize(qb), u);
                out = glm::vec4(q.x, q.y, q.z, q.w);
            } else {
                out = glm::mix(a, b, u);
            }
            break;
        case KeyInterpolation::CubicSpline: {
            // glTF's Hermite spline: tangents are per second, scaled by the interval.
            const glm::vec4 outTangent = valueAt(c, i - 1, 2) * span, inTangent = valueAt(c, i, 0) * span;
            const float u2 = u * u, u3 = u2 * u;
            out = (2.0f * u3 - 3.0f * u2 + 1.0f) * a + (u3 - 2.0f * u2 + u) * outTangent + (-2.0f * u3 + 3.0f * u2) * b +
                  (u3 - u2) * inTangent;
            break;
        }
        }
    }
    return rotation ? normalizedRotation(out) : glm::vec4(glm::vec3(out), 0.0f);
}

void applyNodeAnimation(const NodeAnimation& animation, float timeS, SceneGraph& graph)
{
    for (const NodeRestPose& rest : animation.rest) {
        glm::vec3 translation = rest.translation, scale = rest.scale;
        glm::quat rotation = rest.rotation;
        for (const NodeChannel& c : animation.channels) {
            if (c.node != rest.node) continue;
            const glm::vec4 v = sample(c, timeS);
            if (c.path == ChannelPath::Translation) translation = glm::vec3(v);
            else if (c.path == ChannelPath::Scale) scale = glm::vec3(v);
            else rotation = glm::quat(v.w, v.x, v.y, v.z);
        }
        const glm::mat4 local =
            glm::translate(glm::mat4(1.0f), translation) * glm::mat4_cast(rotation) * glm::scale(glm::mat4(1.0f), scale);
        graph.setLocal(rest.node, local);
    }
}

} // namespace penumbra::scene
