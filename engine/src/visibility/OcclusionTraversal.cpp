#include "visibility/OcclusionTraversal.h"

#include "penumbra/core/Error.h"
#include "penumbra/gpu/Barrier.h"
#include "penumbra/gpu/Check.h"
#include "penumbra/gpu/Context.h"
#include "penumbra/gpu/ShaderCompiler.h"
#include "visibility/ReceiverMask.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <optional>
#include <span>

namespace penumbra::visibility {

// One box of an occlusion query (occlusion_box.vert Boxes). Outside the anonymous
// namespace: OcclusionTraversal::RoundRecorder, a member class, holds a pointer to it.
struct GpuBox {
    glm::vec4 lo;
    glm::vec4 hi;
};

namespace {

constexpr VkFormat kOccluderDepthFormat = VK_FORMAT_D32_SFLOAT;

// lavapipe (PLATFORM.md): in a long run of queries inside one rendering instance about
// one in 1,000 over-counts; ending and resuming rendering every few hundred keeps them
// exact. (An over-count only costs culling; it is never wrong.)
constexpr uint32_t kQueriesPerRendering = 256;
// CHC++ multi-queries: nodes invisible for this many frames in a row are queried in
// batches of up to kMultiQueryBatch; a batch that finds samples is queried node by node
// in the next round.
constexpr uint16_t kMultiQueryAfterFrames = 2;
constexpr uint32_t kMultiQueryBatch = 8;
// A leaf drawn without waiting (visible last frame) whose draw finds no sample is drawn
// so again for up to this many frames before its box is queried again. A box can show
// around geometry that never counts (a lit receiver that shadows nothing: its box takes
// no bias), and without this such a leaf would alternate between a draw and a chain of
// query rounds every other frame.
constexpr uint8_t kEmptyDrawFrames = 8;
// Inner nodes whose projection covers more than this fraction of the view are opened
// without a query.
constexpr float kOpenWithoutQueryFraction = 1.0f / 64.0f;

struct CulledQueryPush {  // culling_mask.frag / occlusion_box.vert Push
    glm::mat4 viewProj;
    int32_t maskBlock;
};



// A box a little larger than `box`, so that no rasterization tie rule lets geometry on
// its faces produce a sample that the box does not.
GpuBox inflated(const scene::Aabb& box)
{
    const glm::vec3 extent = box.max - box.min;
    const float scale = std::max({extent.x, extent.y, extent.z, glm::length(box.min), glm::length(box.max)});
    const glm::vec3 pad(1e-3f * std::max({extent.x, extent.y, extent.z}) + 1e-6f * scale);
    return {glm::vec4(box.min - pad, 1.0f), glm::vec4(box.max + pad, 1.0f)};
}

float distanceSq(const glm::vec3& p, const scene::Aabb& box)
{
    const glm::vec3 d = glm::max(glm::max(box.min - p, p - box.max), glm::vec3(0.0f));
    return glm::dot(d, d);
}

} // namespace

bool outside(const scene::Frustum& f, const scene::Aabb& box)
{
    for (uint32_t i = 0; i < f.planeCount; ++i) {
        const glm::vec4& p = f.planes[i];
        const glm::vec3 far(p.x >= 0 ? box.max.x : box.min.x, p.y >= 0 ? box.max.y : box.min.y,
                            p.z >= 0 ? box.max.z : box.min.z);
        if (glm::dot(glm::vec3(p), far) + p.w < 0.0f) return true;
    }
    return false;
}

std::optional<ProjectedBox> projectBox(const glm::mat4& viewProj, const scene::Aabb& box, uint32_t width,
                                       uint32_t height)
{
    glm::vec2 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
    float nearest = -std::numeric_limits<float>::max();
    for (int c = 0; c < 8; ++c) {
        const glm::vec4 clip = viewProj * glm::vec4(box.corner(c), 1.0f);
        if (!(clip.w > 0.0f) || clip.z > clip.w) return std::nullopt;
        const glm::vec2 p = (glm::vec2(clip) / clip.w * 0.5f + 0.5f) * glm::vec2(float(width), float(height));
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
        nearest = std::max(nearest, clip.z / clip.w);
    }
    // Clamped to the view: only covered texels cost, and a box larger than the view
    // still covers it whole.
    const glm::vec2 size{float(width), float(height)};
    return ProjectedBox{
        {glm::clamp(lo - 1.0f, glm::vec2(-1.0f), size), glm::clamp(hi + 1.0f, glm::vec2(-1.0f), size)}, nearest};
}

glm::vec3 viewOrigin(const glm::mat4& viewProj, float sceneRadius)
{
    const glm::mat4 inv = glm::inverse(viewProj);
    const glm::vec4 eye = inv * glm::vec4(0.0f, 0.0f, 1.0f, 0.0f);
    const glm::vec4 nearCentre = inv * glm::vec4(0.0f, 0.0f, 1.0f, 1.0f);
    const glm::vec3 centre = glm::vec3(nearCentre) / nearCentre.w;
    const float scale = std::max(glm::length(glm::vec3(eye)), 1e-30f);
    if (std::abs(eye.w) > 1e-6f * scale) return glm::vec3(eye) / eye.w;
    return centre + glm::normalize(glm::vec3(eye)) * (4.0f * std::max(sceneRadius, 1e-6f));
}

OccluderDepth::OccluderDepth(gpu::Context& context, uint32_t width, uint32_t height, VkImageUsageFlags usage,
                             const std::string& name)
    : width(width),
      height(height),
      image(context, {width, height, kOccluderDepthFormat, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | usage, name})
{}

// One traversal: its inputs, and what carries over from one round to the next.
struct OcclusionTraversal::Traversal {
    enum class QueryKind { Box, Batch, Leaf };
    struct Query {
        QueryKind kind;
        uint32_t node;        // Box, Leaf
        uint32_t batchFirst;  // Batch: range in batchNodes
        uint32_t batchCount;
    };
    struct Seed {
        uint32_t node;
        bool alone;  // queried on its own (a multi-query that found samples)
    };

    OccluderDepth& depth;
    const TraversalView& view;
    NodeHistory& history;
    std::vector<uint8_t>& visible;
    CullingStats& stats;
    scene::Frustum frustum;
    glm::vec3 origin;
    std::vector<uint8_t> nextVisible;  // per node: history.visible for the next frame
    // This round's queries, in the order of their indices from queryBase, and the nodes
    // of its multi-queries.
    std::vector<Query> issued;
    std::vector<uint32_t> batchNodes;
    uint32_t queryBase = 0;
    bool firstRound = true;
    // What the next round starts from: the nodes to walk from, and the leaves to draw
    // first (found visible in this round).
    std::vector<Seed> seeds{{0, false}};
    std::vector<uint32_t> leavesToDraw;
};

// Records one round's draws and queries into one command buffer, inside dynamic
// rendering into the occluder depth, with the pipeline state that each needs.
class OcclusionTraversal::RoundRecorder {
public:
    RoundRecorder(OcclusionTraversal& owner, Traversal& t, VkCommandBuffer cmd)
        : owner_(owner),
          t_(t),
          cmd_(cmd),
          boxes_(static_cast<GpuBox*>(owner.boxes_.mapped())),
          boxCapacity_(owner.boxes_.size() / sizeof(GpuBox))
    {
        depthAttachment_.imageView = t.depth.image.view();
        depthAttachment_.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
        depthAttachment_.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
        depthAttachment_.clearValue.depthStencil = {0.0f, 0};
        rendering_.renderArea = t.view.area;
        rendering_.layerCount = 1;
        rendering_.pDepthAttachment = &depthAttachment_;
        beginRendering(t.firstRound);
    }

    // Draws a leaf's instances as one query: they occlude what follows, and the query
    // says whether any of them is visible.
    void drawLeaf(uint32_t node)
    {
        const std::span<const uint32_t> instances = owner_.bvh_.leafInstances(node);
        beginQuery();
        for (const bool seeThrough : {false, true}) {
            // See-through instances (alpha-masked, translucent) are counted but write no
            // depth: their holes, and what a translucent surface lets through, must not be
            // occluded by them (a deep shadow map draws the casters behind a pane).
            const bool masked = t_.view.mask != nullptr;
            const gpu::Pipeline& p = masked ? (seeThrough ? owner_.maskLeafCount_ : owner_.maskLeafDepth_)
                                            : (seeThrough ? owner_.leafCount_ : owner_.leafDepth_);
            use(p, false);
            owner_.sceneGpu_.drawInstances(cmd_, instances, seeThrough);
        }
        endQuery({Traversal::QueryKind::Leaf, node, 0, 0});
        // The camera keeps what it draws (the G-buffer follows this list); a light view
        // keeps a leaf when its draw finds samples (processQueryResult).
        if (!t_.view.lightView)
            for (const uint32_t i : instances) t_.visible[i] = 1;
    }

    // Queries a node's box, alone or, hidden for several frames, in a multi-query.
    void queryBox(uint32_t node, bool alone)
    {
        if (!alone && t_.history.hidden[node] >= kMultiQueryAfterFrames) {
            batch_.push_back(node);
            if (batch_.size() == kMultiQueryBatch) flushBatch();
            return;
        }
        drawBoxes(pushBox(node), 1, {Traversal::QueryKind::Box, node, 0, 0});
    }

    // Issues the pending multi-query and ends rendering.
    void finish()
    {
        flushBatch();
        vkCmdEndRendering(cmd_);
    }

private:
    void beginRendering(bool clear)
    {
        depthAttachment_.loadOp = clear ? VK_ATTACHMENT_LOAD_OP_CLEAR : VK_ATTACHMENT_LOAD_OP_LOAD;
        vkCmdBeginRendering(cmd_, &rendering_);
        const VkViewport viewport{0.0f, 0.0f, float(t_.depth.width), float(t_.depth.height), 0.0f, 1.0f};
        const VkRect2D scissor = t_.view.area;
        vkCmdSetViewport(cmd_, 0, 1, &viewport);
        vkCmdSetScissor(cmd_, 0, 1, &scissor);
        bound_ = nullptr;
        inRendering_ = 0;
    }

    void use(const gpu::Pipeline& p, bool boxPipeline)
    {
        if (bound_ == &p) return;
        p.bind(cmd_);
        const ReceiverMask* mask = t_.view.mask;
        gpu::DescriptorPush push;
        if (boxPipeline)
            push.storageBuffer("Boxes", owner_.boxes_);
        else
            push.storageBuffer("Instances", owner_.sceneGpu_.instanceBuffer());
        if (mask) push.sampledImage("receiverMask", mask->dilated, owner_.nearest_, VK_IMAGE_LAYOUT_GENERAL);
        push.push(owner_.context_, cmd_, p);
        // Leaf draws take the technique's bias in a light view, so that what they draw and
        // what their queries count is the technique's own map (reversed-Z: negated, as in
        // render::ShadowMap). Box proxies take none: the geometry inside lies behind their
        // faces, biased or not.
        const render::ShadowDepthBias bias =
            t_.view.lightView && !boxPipeline ? t_.view.bias : render::ShadowDepthBias{};
        vkCmdSetDepthBias(cmd_, -bias.constant, -bias.clamp, -bias.slope);
        const CulledQueryPush constants{t_.view.viewProj, int32_t(mask ? mask->block : 1)};
        p.pushConstants(cmd_, &constants, mask ? sizeof(constants) : sizeof(glm::mat4));
        bound_ = &p;
    }

    void beginQuery()
    {
        if (inRendering_ == kQueriesPerRendering) {
            vkCmdEndRendering(cmd_);
            gpu::memoryBarrier(
                cmd_, {VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT, VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT},
                {VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
                 VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT});
            beginRendering(false);
        }
        const uint32_t index = t_.queryBase + uint32_t(t_.issued.size());
        if (index >= owner_.queryCapacity_) throw Error("visibility: occlusion query pool exhausted");
        vkCmdBeginQuery(cmd_, owner_.queries_, index, 0);
        ++inRendering_;
        ++t_.stats.queriesIssued;
    }

    void endQuery(const Traversal::Query& q)
    {
        vkCmdEndQuery(cmd_, owner_.queries_, t_.queryBase + uint32_t(t_.issued.size()));
        t_.issued.push_back(q);
    }

    uint32_t pushBox(uint32_t node)
    {
        if (boxCount_ >= boxCapacity_) throw Error("visibility: box buffer exhausted");
        boxes_[boxCount_] = inflated(owner_.bvh_.nodeBounds(node));
        return boxCount_++;
    }

    // One query over `count` boxes from `first` in the box buffer (one instanced draw).
    void drawBoxes(uint32_t first, uint32_t count, const Traversal::Query& q)
    {
        use(t_.view.mask ? owner_.maskBox_ : owner_.box_, true);
        beginQuery();
        vkCmdDraw(cmd_, 36, count, 0, first);
        endQuery(q);
    }

    void flushBatch()
    {
        if (batch_.empty()) return;
        if (batch_.size() == 1) {
            drawBoxes(pushBox(batch_[0]), 1, {Traversal::QueryKind::Box, batch_[0], 0, 0});
        } else {
            const uint32_t first = boxCount_;
            for (const uint32_t n : batch_) pushBox(n);
            drawBoxes(first, uint32_t(batch_.size()),
                      {Traversal::QueryKind::Batch, 0, uint32_t(t_.batchNodes.size()), uint32_t(batch_.size())});
            t_.batchNodes.insert(t_.batchNodes.end(), batch_.begin(), batch_.end());
        }
        batch_.clear();
    }

    OcclusionTraversal& owner_;
    Traversal& t_;
    const VkCommandBuffer cmd_;
    GpuBox* const boxes_;
    const size_t boxCapacity_;
    uint32_t boxCount_ = 0;
    VkRenderingAttachmentInfo depthAttachment_{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
    VkRenderingInfo rendering_{VK_STRUCTURE_TYPE_RENDERING_INFO};
    const gpu::Pipeline* bound_ = nullptr;
    uint32_t inRendering_ = 0;  // queries since rendering (re)started
    std::vector<uint32_t> batch_;  // nodes waiting for a multi-query
};

OcclusionTraversal::OcclusionTraversal(gpu::Context& context, const gpu::ShaderCompiler& shaders,
                                       const scene::Scene& scene, const render::SceneGpu& sceneGpu,
                                       const scene::InstanceBvh& bvh, bool withMask)
    : context_(context), scene_(scene), sceneGpu_(sceneGpu), bvh_(bvh)
{
    const gpu::VertexLayout positions{sceneGpu_.vertexStride(),
                                      {{0, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(scene::Vertex, position)}}};
    gpu::GraphicsPipelineDesc d;
    d.vertexShader = "engine/shadow_depth.vert";
    d.pushConstantBytes = sizeof(glm::mat4);
    d.vertexLayout = positions;
    d.depthFormat = kOccluderDepthFormat;
    d.depthCompare = VK_COMPARE_OP_GREATER_OR_EQUAL;
    d.depthBias = true;
    d.cullMode = VK_CULL_MODE_NONE;
    const auto make = [&](const char* name, bool depthWrite) {
        d.name = std::string("visibility.") + name;
        d.depthWrite = depthWrite;
        return gpu::Pipeline(context_, shaders, d);
    };
    leafDepth_ = make("leaf", true);
    leafCount_ = make("leaf_count", false);
    gpu::GraphicsPipelineDesc boxDesc = d;
    boxDesc.vertexShader = "engine/occlusion_box.vert";
    boxDesc.vertexLayout = {};
    boxDesc.name = "visibility.box";
    boxDesc.depthWrite = false;
    box_ = gpu::Pipeline(context_, shaders, boxDesc);
    if (withMask) {
        d.fragmentShader = "engine/culling_mask.frag";
        d.pushConstantBytes = sizeof(CulledQueryPush);
        maskLeafDepth_ = make("mask_leaf", true);
        maskLeafCount_ = make("mask_leaf_count", false);
        boxDesc.fragmentShader = d.fragmentShader;
        boxDesc.pushConstantBytes = d.pushConstantBytes;
        boxDesc.name = "visibility.mask_box";
        maskBox_ = gpu::Pipeline(context_, shaders, boxDesc);
        nearest_ = gpu::createSampler(context_, VK_FILTER_NEAREST, VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE);
    }

    // A node is queried at most three times in one traversal (in a multi-query, alone,
    // and as a drawn leaf); a tree over n instances has fewer than 2 n nodes.
    const uint64_t maxNodes = 2 * uint64_t(std::max<size_t>(scene.instances.size(), 1));
    queryCapacity_ = uint32_t(std::min<uint64_t>(3 * maxNodes + 64, UINT32_MAX));
    VkQueryPoolCreateInfo q{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
    q.queryType = VK_QUERY_TYPE_OCCLUSION;
    q.queryCount = queryCapacity_;
    PENUMBRA_VK(vkCreateQueryPool(context_.device(), &q, nullptr, &queries_));
    boxes_ = gpu::Buffer(context_, (maxNodes + 64) * sizeof(GpuBox), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true,
                         "visibility.boxes");
}

OcclusionTraversal::~OcclusionTraversal()
{
    if (queries_) vkDestroyQueryPool(context_.device(), queries_, nullptr);
}

void OcclusionTraversal::cull(OccluderDepth& depth, const TraversalView& view, NodeHistory& history,
                              std::vector<uint8_t>& visible, CullingStats& stats)
{
    const size_t nodeCount = bvh_.nodeCount();
    visible.assign(scene_.instances.size(), 0);
    if (history.visible.size() != nodeCount) {
        // First frame, or a rebuilt tree: nothing is known, so the root is queried.
        history.visible.assign(nodeCount, 0);
        history.hidden.assign(nodeCount, 0);
        history.emptyDraws.assign(nodeCount, 0);
    }
    if (nodeCount == 0) return;

    Traversal t{depth,
                view,
                history,
                visible,
                stats,
                scene::frustumFromViewProj(view.viewProj),
                viewOrigin(view.viewProj, scene_.bounds().radius()),
                std::vector<uint8_t>(nodeCount, 0)};
    while (!t.seeds.empty() || !t.leavesToDraw.empty()) {
        t.issued.clear();
        t.batchNodes.clear();
        context_.submitAndWait([&](VkCommandBuffer cmd) { recordRound(cmd, t); });
        ++stats.queryRounds;
        t.firstRound = false;
        readRoundResults(t);
    }
    endTraversal(t);
}

void OcclusionTraversal::recordRound(VkCommandBuffer cmd, Traversal& t)
{
    // The previous submission's writes (last round, last view, last frame).
    gpu::memoryBarrier(cmd, {VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_WRITE_BIT},
                       {VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT});
    if (t.firstRound) vkCmdResetQueryPool(cmd, queries_, 0, queryCapacity_);
    if (t.depth.layout != VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL) {
        gpu::transition(cmd, t.depth.image,
                        {t.depth.layout, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_READ_BIT},
                        gpu::access::kDepthAttachment);
        t.depth.layout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
    }
    RoundRecorder round(*this, t, cmd);
    // Leaves found visible in the last round are drawn first: they occlude.
    for (const uint32_t leaf : t.leavesToDraw) round.drawLeaf(leaf);
    walkFrontToBack(t, round);
    round.finish();
}

// CHC++'s traversal queue: from the seeds, nearest box first; each node is drawn (a
// leaf), opened (an inner node) or queried, unless it is outside the view or the mask.
void OcclusionTraversal::walkFrontToBack(Traversal& t, RoundRecorder& round)
{
    struct Entry {
        float distanceSq;
        uint32_t node;
        bool alone;
    };
    const auto farther = [](const Entry& a, const Entry& b) {
        return a.distanceSq > b.distanceSq || (a.distanceSq == b.distanceSq && a.node > b.node);
    };
    std::vector<Entry> heap;
    const auto push = [&](uint32_t node, bool alone) {
        const scene::Aabb& box = bvh_.nodeBounds(node);
        if (box.empty()) return;
        heap.push_back({distanceSq(t.origin, box), node, alone});
        std::push_heap(heap.begin(), heap.end(), farther);
    };
    for (const Traversal::Seed& s : t.seeds) push(s.node, s.alone);
    const uint32_t width = t.depth.width, height = t.depth.height;
    while (!heap.empty()) {
        std::pop_heap(heap.begin(), heap.end(), farther);
        const Entry e = heap.back();
        heap.pop_back();
        ++t.stats.nodesVisited;
        const scene::Aabb& box = bvh_.nodeBounds(e.node);
        if (outside(t.frustum, box)) continue;
        const std::optional<ProjectedBox> projected = projectBox(t.view.viewProj, box, width, height);
        const std::optional<TexelRect> rect = projected ? std::optional(projected->rect) : std::nullopt;
        if (t.view.mask && rect && t.view.mask->rejects(*rect)) {
            ++t.stats.maskRejected;
            continue;
        }
        // No projection (the box reaches the near plane): visible without a query. An
        // inner node whose proxy would cover a large part of the view is opened without
        // one too: its query would cost as much as its children's and would rarely find
        // nothing (lavapipe rasterises every covered texel).
        const bool leaf = bvh_.isLeafNode(e.node);
        const bool known = t.history.visible[e.node] != 0 || !rect ||
                           (!leaf && rect->area() > kOpenWithoutQueryFraction * float(width) * float(height));
        if (leaf && known) {
            round.drawLeaf(e.node);
        } else if (known) {
            push(bvh_.firstChild(e.node), false);
            push(bvh_.firstChild(e.node) + 1, false);
        } else {
            round.queryBox(e.node, e.alone);
        }
    }
}

// Waits for the round's query results and turns them into the next round's seeds and
// leaves.
void OcclusionTraversal::readRoundResults(Traversal& t)
{
    std::vector<uint64_t> samples(t.issued.size(), 0);
    if (!t.issued.empty()) {
        PENUMBRA_VK(vkGetQueryPoolResults(context_.device(), queries_, t.queryBase, uint32_t(t.issued.size()),
                                          samples.size() * sizeof(uint64_t), samples.data(), sizeof(uint64_t),
                                          VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT));
    }
    t.queryBase += uint32_t(t.issued.size());
    t.seeds.clear();
    t.leavesToDraw.clear();
    for (size_t i = 0; i < t.issued.size(); ++i) processQueryResult(t, i, samples[i]);
}

void OcclusionTraversal::processQueryResult(Traversal& t, size_t query, uint64_t samples)
{
    const Traversal::Query& q = t.issued[query];
    NodeHistory& history = t.history;
    if (samples == 0) {
        if (q.kind == Traversal::QueryKind::Leaf && history.emptyDraws[q.node] < kEmptyDrawFrames) {
            t.nextVisible[q.node] = 1;  // drawn without waiting next frame too
            ++history.emptyDraws[q.node];
        }
        return;
    }
    switch (q.kind) {
    case Traversal::QueryKind::Leaf:
        t.nextVisible[q.node] = 1;
        history.emptyDraws[q.node] = 0;
        // A light view's leaf whose draw found no sample lies, at every texel that a
        // receiver reads and where it lies in front of one, behind casters drawn before it
        // in the technique's own biased depth: it cannot change what a receiver gets,
        // though its box showed (a large lit receiver's box does).
        if (t.view.lightView)
            for (const uint32_t i : bvh_.leafInstances(q.node)) t.visible[i] = 1;
        break;
    case Traversal::QueryKind::Box:
        // A node whose box shows is opened (or, a leaf, drawn) without waiting next frame,
        // even if its own geometry turns out hidden: otherwise a box that shows around
        // hidden geometry would send its subtree through the same chain of rounds every
        // frame. A leaf drawn that way is queried by its draw, which unmarks it when the
        // geometry stays hidden (after kEmptyDrawFrames such draws).
        t.nextVisible[q.node] = 1;
        history.emptyDraws[q.node] = 0;
        if (bvh_.isLeafNode(q.node)) {
            t.leavesToDraw.push_back(q.node);
        } else {
            t.seeds.push_back({bvh_.firstChild(q.node), false});
            t.seeds.push_back({bvh_.firstChild(q.node) + 1, false});
        }
        break;
    case Traversal::QueryKind::Batch:
        for (uint32_t k = 0; k < q.batchCount; ++k) t.seeds.push_back({t.batchNodes[q.batchFirst + k], true});
        break;
    }
}

// Visibility pulled up the tree for the next frame (children come after parents), and
// the count of frames each node has stayed hidden.
void OcclusionTraversal::endTraversal(Traversal& t)
{
    std::vector<uint8_t>& next = t.nextVisible;
    std::vector<uint16_t>& hidden = t.history.hidden;
    for (size_t n = next.size(); n-- > 1;)
        if (next[n]) next[bvh_.parentNode(uint32_t(n))] = 1;
    for (size_t n = 0; n < next.size(); ++n) hidden[n] = next[n] ? 0 : uint16_t(std::min(hidden[n] + 1, 0xffff));
    t.history.visible.swap(next);
}

} // namespace penumbra::visibility
