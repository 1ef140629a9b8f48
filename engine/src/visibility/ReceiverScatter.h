#pragma once
// The receiver scatter of ReceiverMask.h on the host: engine/receiver_scatter.comp's
// arithmetic per camera pixel (the same float operations in the same order), and
// engine/receiver_depth_min.comp's spreading over the taps, here restricted to the texels
// a receiver depth can reach.
//
// Why on the host at all: on a CPU device (lavapipe) the shader's scattered stores and
// atomics run lane by lane, and its arithmetic costs several times its count; on
// config/bench/streets/street-c.json (1280 x 720, a 4096² map) its mask step took 40-50
// ms, the host's about 25 ms with two cores (docs/culling.md, "The receiver scatter on
// the host"). The receiver depths and the marks are read on the host anyway. On a GPU
// the shaders stay (ReceiverMaskBuilder picks by the device's type).
#include <glm/glm.hpp>

#include <cstdint>
#include <span>

namespace penumbra::visibility {

// The camera the receivers are seen from: its depth (reversed-Z, 0 where nothing was
// drawn), row by row, width x height.
struct ScatterCamera {
    glm::mat4 inverseViewProj{1.0f};
    glm::vec3 eye{0.0f};  // OcclusionTraversal.h viewOrigin
    uint32_t width = 0, height = 0;
    std::span<const float> depth;
};

// One light view's targets: `marks` (maskSize² words, a non-zero word per marked mask
// texel) and, when not empty, `receiverDepth` (resolution² words: the bits of the
// farthest receiver depth per texel, all ones for none), both as receiver_scatter.comp
// writes them (marks are only set, depths only lowered).
struct ScatterView {
    glm::mat4 lightViewProj{1.0f};
    uint32_t resolution = 0;  // view texels per side
    uint32_t block = 1;       // view texels per mask texel, per side
    uint32_t maskSize = 0;    // mask texels per side
    std::span<uint32_t> marks;
    std::span<uint32_t> receiverDepth;
};

// The view texels [x0, x1] x [y0, y1] a scatter wrote receiver depths to; empty when
// x0 > x1.
struct TexelBounds {
    uint32_t x0 = UINT32_MAX, y0 = UINT32_MAX, x1 = 0, y1 = 0;
    bool empty() const { return x0 > x1; }
};

// Marks, for every camera pixel with geometry whose surface point lies in the light
// view, the mask texel of its view texel, and lowers the receiver depths around it
// (receiver_scatter.comp). Returns where depths were written.
TexelBounds scatterReceivers(const ScatterCamera& camera, const ScatterView& view);

// Every texel of `depth` (size² words) gets the least value within `radius` texels (a
// square), as receiver_depth_min.comp does over the whole view; only the texels within
// `radius` of `written` can change, and only they are visited.
void spreadReceiverDepth(std::span<uint32_t> depth, uint32_t size, uint32_t radius, const TexelBounds& written);

} // namespace penumbra::visibility
