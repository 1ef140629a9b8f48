#pragma once
// Step 2 of Mattausch et al. (Visibility.h): the receiver mask of a light view, the texels
// that the camera's visible pixels look up. Each camera pixel, unprojected from the camera
// depth, marks its texel (engine/receiver_scatter.comp: the reverse shadow test, done from
// the camera's side); the mask is read back, dilated by the view's footprint on the host
// and summed into a summed-area table, so that the traversal can skip, without a query,
// every node whose projection meets no marked texel. A view whose technique compares with
// the receivers' own depth also gets the farthest receiver depth per texel, spread over
// the technique's taps (engine/receiver_depth_min.comp), and, on the host, its least value
// per mask texel, the receiver floor, in a min pyramid: the traversal skips, without a
// query, every node whose box lies behind the floor wherever it is projected.
//
// The paper also rasterises the receivers' depth here, as the start of the shadow map.
// Here the technique draws its own map, so that pass would draw the receivers twice (in a
// bird's-eye view, most of the scene: measured 400 ms of 1.3 s on lavapipe,
// docs/culling.md). The queries are tested against the depth of what the traversal itself
// draws instead; it is all drawn into the technique's map too, so a node behind it at
// every masked texel is still one that cannot change a masked texel.
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/gpu/Resources.h"
#include "penumbra/render/Casters.h"

#include <glm/glm.hpp>

#include <algorithm>
#include <cstdint>
#include <map>
#include <span>
#include <vector>

namespace penumbra::gpu {
class Context;
class ShaderCompiler;
} // namespace penumbra::gpu

namespace penumbra::visibility {

// Receiver depths (engine/receiver_scatter.comp RECEIVER_DEPTH) and the receiver floor: the
// bits of a non-negative float, all ones where no receiver reads the texel.
inline constexpr VkFormat kReceiverDepthFormat = VK_FORMAT_R32_UINT;

// The view texels a box's projection can cover (OcclusionTraversal.cpp projectedRect).
struct TexelRect {
    glm::vec2 lo, hi;
    float area() const { return std::max(hi.x - lo.x, 0.0f) * std::max(hi.y - lo.y, 0.0f); }
};

// Texels [begin, end) of one row; empty when begin >= end.
struct RowSpan {
    uint32_t begin = 0, end = 0;
};

// The receiver mask of the light view last built at one resolution.
struct ReceiverMask {
    uint32_t resolution = 0;  // the view's texels per side
    uint32_t size = 0;        // mask texels per side
    uint32_t block = 1;       // view texels per mask texel, per side
    gpu::Buffer marked;                // the scatter's marks, a word per mask texel, host-visible
    gpu::Image dilated;                // the dilated mask, for the queries (views without receiver depths)
    gpu::Buffer upload;                // host-visible: the dilated mask on its way into `dilated`
    std::vector<uint8_t> dilatedTexels;  // the dilated mask on the host, 0 or 255
    std::vector<uint32_t> summedArea;  // of the dilated mask, (size + 1)^2
    std::vector<RowSpan> markedRows;   // per mask row, the span of its dilated mask's texels (mask texels)
    // Views whose technique compares with the receivers' own depth: the farthest receiver
    // depth per view texel, and the scratch of its spreading over the taps; made on
    // first use.
    // Row by row, host-visible (the CPU culling reads it).
    gpu::Buffer receiverDepth, receiverDepthPrefix;
    bool hasReceiverDepth = false;  // this view's receiver depths are in receiverDepth
    // Per view row, the texels [begin, end) where receiverDepth may hold a depth
    // (elsewhere it is all ones): the next build clears only these. On lavapipe the fill
    // of a whole 4096² buffer (64 MB) took a third of a street view's mask
    // (docs/culling.md); the camera's receivers cover a fifth of such a map or less.
    std::vector<RowSpan> receiverDepthWritten;
    // With receiver depths: per mask texel of the dilated mask the least receiver depth of
    // its block, as floats (+infinity for none) in floorLevels[0], and in each next level
    // the least of 2 x 2 cells of the last.
    std::vector<std::vector<float>> floorLevels;
    // The view texels that the marked mask texels cover: the queries render only there.
    VkRect2D bounds{};

    // Whether no mask texel in `rect` (view texels, inclusive) is marked, so that no
    // fragment of a query inside it could pass the mask test.
    bool rejects(const TexelRect& rect) const;

    // With receiver depths: whether a box whose nearest light depth (reversed-Z: the
    // largest) is `nearestDepth` lies behind every receiver depth in `rect` (view texels),
    // so that no sample of it inside could pass the receiver-depth test there. False
    // without receiver depths.
    bool behindReceivers(const TexelRect& rect, float nearestDepth) const;

    // With receiver depths: the bits of the least receiver depth that reads view texel
    // (x, y), all ones for none.
    uint32_t receiverDepthBits(uint32_t x, uint32_t y) const
    {
        return static_cast<const uint32_t*>(receiverDepth.mapped())[size_t(y) * resolution + x];
    }
};

// The receiver floor's min pyramid (ReceiverMask::floorLevels) from its `size`² texels as
// read back (all ones: none): level 0 holds them as floats, each next level the least of
// 2 x 2 cells of the last (an odd side's last cell takes what it has), down to 1 x 1.
std::vector<std::vector<float>> floorPyramid(std::span<const uint32_t> floorBits, uint32_t size);

// Where the receivers are scattered into a view's mask and receiver depths: by the device
// (engine/receiver_scatter.comp, engine/receiver_depth_min.comp) or by the host
// (ReceiverScatter.h, from the camera depth read back once a frame). Both give the same
// marks and depths up to the rounding of the same float operations.
enum class ScatterPlacement { Device, Host };

// The host on a CPU device, where the shader's scattered stores run lane by lane and the
// host loop is several times faster (ReceiverScatter.h); the device elsewhere. The
// environment variable PENUMBRA_RECEIVER_SCATTER (host, device or auto) overrides it, to
// compare the two; any other value throws, naming it.
inline constexpr const char* kScatterPlacementVariable = "PENUMBRA_RECEIVER_SCATTER";
ScatterPlacement scatterPlacementFor(const gpu::Context& context);

// Builds the receiver masks: their pipelines, the camera they are scattered from, and one
// mask per light-view resolution (views of one resolution share it, one after another).
class ReceiverMaskBuilder {
public:
    ReceiverMaskBuilder(gpu::Context& context, const gpu::ShaderCompiler& shaders, ScatterPlacement placement);

    // This frame's camera: its depth (reversed-Z, in DEPTH_READ_ONLY_OPTIMAL, which must
    // outlive the builder), its world -> clip matrix, and its eye (OcclusionTraversal.h
    // viewOrigin).
    void setCamera(const gpu::Image& depth, const glm::mat4& viewProj, const glm::vec3& eye);

    // The mask of `view` (resolution > 0), with its receiver depths when the view's
    // technique compares with them (CasterView::compareTapRadius >= 0). On the device: one
    // submission, waited for; on the host: none but the camera depth's read-back, once a
    // frame.
    const ReceiverMask& build(const render::CasterView& view);

    ScatterPlacement placement() const { return placement_; }

private:
    ReceiverMask& maskFor(uint32_t resolution);
    void makeReceiverDepth(ReceiverMask& mask, bool withPrefix);
    void recordMask(VkCommandBuffer cmd, ReceiverMask& mask, const render::CasterView& view, int32_t tapRadius);
    void scatterOnHost(ReceiverMask& mask, const render::CasterView& view, int32_t tapRadius);
    void readCameraDepth();
    void uploadDilated(const ReceiverMask& mask);
    void sumMarkedTexels(ReceiverMask& mask);
    void buildFloorPyramid(ReceiverMask& mask);

    gpu::Context& context_;
    const ScatterPlacement placement_;
    const gpu::Image* cameraDepth_ = nullptr;
    std::map<uint32_t, ReceiverMask> masks_;  // by resolution
    // On the device: the scatter (with and without receiver depths), the receivers'
    // depths spread over the taps, and the camera they read.
    gpu::Pipeline scatter_, scatterDepth_;
    gpu::Pipeline depthMin_;
    gpu::Sampler nearest_;
    gpu::Buffer cameraData_;
    // On the host: the camera, and its depth once read back this frame.
    glm::mat4 cameraInverseViewProj_{1.0f};
    glm::vec3 cameraEye_{0.0f};
    gpu::Buffer cameraDepthReadback_;
    bool cameraDepthRead_ = false;
};

} // namespace penumbra::visibility
