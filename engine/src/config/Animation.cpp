#include "penumbra/config/Animation.h"

#include <algorithm>
#include <cassert>

namespace penumbra::config {

std::vector<float> evaluate(const AnimationTrack& track, float timeS)
{
    assert(!track.keys.empty());  // validation guarantees at least one key
    const std::vector<Keyframe>& k = track.keys;
    if (k.size() == 1 || timeS <= k.front().timeS) return k.front().value;
    if (timeS >= k.back().timeS) return k.back().value;
    // First key after timeS: keys are strictly increasing (validated), so i >= 1.
    const size_t i = static_cast<size_t>(
        std::upper_bound(k.begin(), k.end(), timeS, [](float t, const Keyframe& key) { return t < key.timeS; }) -
        k.begin());
    const Keyframe& a = k[i - 1];
    const Keyframe& b = k[i];
    if (track.interpolation == Interpolation::Step) return a.value;
    // Strictly increasing times make the span positive; no division by zero.
    const float u = (timeS - a.timeS) / (b.timeS - a.timeS);
    std::vector<float> out(a.value.size());
    if (track.interpolation == Interpolation::Linear) {
        for (size_t c = 0; c < out.size(); ++c) out[c] = a.value[c] + u * (b.value[c] - a.value[c]);
        return out;
    }
    // Catmull-Rom (uniform in parameter, tangents scaled to the span lengths so that
    // uneven key spacing does not overshoot); the missing neighbour at either end
    // repeats the end key, giving a one-sided tangent.
    const Keyframe& p0 = i >= 2 ? k[i - 2] : a;
    const Keyframe& p3 = i + 1 < k.size() ? k[i + 1] : b;
    const float span = b.timeS - a.timeS;
    const float u2 = u * u, u3 = u2 * u;
    for (size_t c = 0; c < out.size(); ++c) {
        const float spanA = std::max(b.timeS - p0.timeS, 1e-30f);
        const float spanB = std::max(p3.timeS - a.timeS, 1e-30f);
        const float m0 = (b.value[c] - p0.value[c]) / spanA * span;
        const float m1 = (p3.value[c] - a.value[c]) / spanB * span;
        out[c] = (2 * u3 - 3 * u2 + 1) * a.value[c] + (u3 - 2 * u2 + u) * m0 + (-2 * u3 + 3 * u2) * b.value[c] +
                 (u3 - u2) * m1;
    }
    return out;
}

} // namespace penumbra::config
