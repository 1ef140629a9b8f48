#pragma once
// Hierarchical occlusion culling (CHC++, Mattausch, Bittner and Wimmer 2008) over the
// scene's instance BVH, with occlusion queries that are waited for within the frame, so
// that the result is exact for the frame and never a frame late: the traversal runs in
// rounds, each one submission. Round 0 walks the tree front to back, draws the leaves
// visible last frame at once (temporal coherence: no waiting for them; their own draw is
// their query for the next frame) and queries the boxes of nodes that were invisible
// (nodes invisible for several frames share one multi-query per batch). Each later round
// draws the leaves and queries the children of the nodes whose queries found samples,
// until no query is pending. A query that finds no samples proves its node hidden behind
// geometry already drawn, so nothing visible is ever culled.
//
// The camera and the light views (Visibility.h) run the same traversal; a light view in
// receiver-mask mode runs it behind its receiver mask (ReceiverMask.h).
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/gpu/Resources.h"
#include "penumbra/render/Casters.h"
#include "penumbra/render/SceneGpu.h"
#include "penumbra/scene/Bvh.h"
#include "penumbra/scene/Scene.h"
#include "penumbra/visibility/CullingStats.h"
#include "visibility/ReceiverMask.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace penumbra::gpu {
class Context;
class ShaderCompiler;
} // namespace penumbra::gpu

namespace penumbra::visibility {

// Per BVH node, what the last frames' traversals of one view found.
struct NodeHistory {
    std::vector<uint8_t> visible;      // visible last frame: opened or drawn without waiting
    std::vector<uint16_t> hidden;      // frames invisible in a row
    std::vector<uint8_t> emptyDraws;   // leaves: draws in a row that found no sample
};

// The depth buffer a traversal draws the visible leaves into and tests its queries
// against: the camera's (which the receiver masks then sample), or a light view's at one
// resolution.
struct OccluderDepth {
    // `usage` beyond the depth attachment's (the camera's is sampled and read back).
    OccluderDepth(gpu::Context& context, uint32_t width, uint32_t height, VkImageUsageFlags usage,
                  const std::string& name);
    uint32_t width = 0, height = 0;
    gpu::Image image;
    VkImageLayout layout = VK_IMAGE_LAYOUT_UNDEFINED;
};

// What one traversal culls for.
struct TraversalView {
    glm::mat4 viewProj{1.0f};
    VkRect2D area{};  // what the traversal renders: the view, or the receiver mask's bounds
    // A light view: leaf draws take the technique's `bias` (boxes take none), and a leaf is
    // kept only when its draw finds samples. The camera keeps every leaf it draws.
    bool lightView = false;
    render::ShadowDepthBias bias;
    // Receiver-mask mode (views without receiver depths): queries count only samples on
    // the mask, and nodes whose projection meets no marked texel are culled without a
    // query.
    const ReceiverMask* mask = nullptr;
};

// Whether `box` lies wholly outside a plane of `frustum`.
bool outside(const scene::Frustum& frustum, const scene::Aabb& box);

// A box's projection into a view: the texels it can cover (with a texel of margin for the
// proxy's inflation and rounding) and its nearest depth (reversed-Z: the largest; at a
// corner, since depth is monotonic along the view for both projections).
struct ProjectedBox {
    TexelRect rect;
    float nearestDepth;
};

// A box's projection into a `width` x `height` view, or nothing when any part of the box
// lies in front of the near plane (or behind the eye): its proxy would be clipped there,
// and a query could miss geometry inside it that the view does see, so such a node is
// treated as visible without a query.
std::optional<ProjectedBox> projectBox(const glm::mat4& viewProj, const scene::Aabb& box, uint32_t width,
                                       uint32_t height);

// Where a front-to-back traversal of a view starts: the eye of a perspective view; for an
// orthographic one a point far behind the near plane's centre, so that distance from it
// orders boxes nearly as depth does.
glm::vec3 viewOrigin(const glm::mat4& viewProj, float sceneRadius);

class OcclusionTraversal {
public:
    // `scene`, `sceneGpu` and `bvh` (over the scene's instances) must outlive the
    // traversal; `withMask`: also the pipelines that test against a receiver mask.
    OcclusionTraversal(gpu::Context& context, const gpu::ShaderCompiler& shaders, const scene::Scene& scene,
                       const render::SceneGpu& sceneGpu, const scene::InstanceBvh& bvh, bool withMask);
    ~OcclusionTraversal();
    OcclusionTraversal(const OcclusionTraversal&) = delete;
    OcclusionTraversal& operator=(const OcclusionTraversal&) = delete;

    // Culls `view`, drawing into `depth` (cleared first): `visible` gets one entry per
    // instance (non-zero: visible), `history` this frame's findings for the next, and
    // `stats` the traversal's counts.
    void cull(OccluderDepth& depth, const TraversalView& view, NodeHistory& history, std::vector<uint8_t>& visible,
              CullingStats& stats);

private:
    struct Traversal;
    class RoundRecorder;

    void recordRound(VkCommandBuffer cmd, Traversal& traversal);
    void walkFrontToBack(Traversal& traversal, RoundRecorder& round);
    void readRoundResults(Traversal& traversal);
    void processQueryResult(Traversal& traversal, size_t query, uint64_t samples);
    void endTraversal(Traversal& traversal);

    gpu::Context& context_;
    const scene::Scene& scene_;
    const render::SceneGpu& sceneGpu_;
    const scene::InstanceBvh& bvh_;

    // Pipelines: depth-only leaf draws (writing depth, or only counting samples for
    // alpha-masked instances), box queries; the same behind the receiver mask.
    gpu::Pipeline leafDepth_, leafCount_, box_;
    gpu::Pipeline maskLeafDepth_, maskLeafCount_, maskBox_;
    gpu::Sampler nearest_;
    gpu::Buffer boxes_;
    VkQueryPool queries_ = VK_NULL_HANDLE;
    uint32_t queryCapacity_ = 0;
};

} // namespace penumbra::visibility
