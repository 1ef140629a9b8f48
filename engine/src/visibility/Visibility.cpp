#include "visibility/Visibility.h"

#include "core/Clock.h"
#include "penumbra/core/Error.h"
#include "penumbra/gpu/Barrier.h"
#include "penumbra/gpu/Context.h"
#include "visibility/ReceiverFloorCulling.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>

namespace penumbra::visibility {
namespace {

// A view whose last full culling kept more than this fraction of the instances in its
// frustum takes its frustum's instances, for up to kRecheckFrames frames.
constexpr double kFallbackKeptFraction = 0.4;
constexpr uint32_t kRecheckFrames = 8;

size_t countMarked(const std::vector<uint8_t>& list) { return size_t(std::count(list.begin(), list.end(), uint8_t(1))); }

} // namespace

SceneBvh::SceneBvh(const scene::Scene& scene) : bvh(scene::instanceWorldBounds(scene.instances)) {}

void SceneBvh::instancesMoved(const scene::Scene& scene, std::span<const uint32_t> moved)
{
    const std::vector<scene::Aabb> bounds = scene::instanceWorldBounds(scene.instances);
    if (bvh.refitOrRebuild(bounds, moved).action == scene::RefitAction::Rebuilt) ++rebuilds;
}

Visibility::Visibility(gpu::Context& context, const gpu::ShaderCompiler& shaders, const scene::Scene& scene,
                       const render::SceneGpu& sceneGpu, const SceneBvh& bvh, config::CullingMode mode, uint32_t width,
                       uint32_t height, bool focus)
    : context_(context),
      scene_(scene),
      mode_(mode),
      width_(width),
      height_(height),
      sceneBvh_(bvh),
      bvh_(bvh.bvh),
      bvhRebuilds_(bvh.rebuilds),
      focusing_(focus)
{
    if (focusing_ && mode_ != config::CullingMode::LightOcclusion && mode_ != config::CullingMode::ReceiverMask) {
        throw ConfigError(fmt::format("shadow_focus needs culling \"receiver-mask\" or \"light-occlusion\", not \"{}\"",
                                      config::cullingModeName(mode_)));
    }
    receivers_.assign(scene.instances.size(), 1);
    if (mode_ == config::CullingMode::None || mode_ == config::CullingMode::Frustum) return;

    // Only what the mode needs: occlusion modes get the traversal, receiver-mask mode the
    // masks too.
    const bool withMask = mode_ == config::CullingMode::ReceiverMask;
    traversal_ = std::make_unique<OcclusionTraversal>(context_, shaders, scene, sceneGpu, bvh_, withMask);
    if (withMask) masks_ = std::make_unique<ReceiverMaskBuilder>(context_, shaders, scatterPlacementFor(context_));
    cameraDepth_.emplace(context_, width_, height_, VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                         "visibility.camera_depth");
}

Visibility::~Visibility() = default;


void Visibility::cullFrustum(const glm::mat4& viewProj, std::vector<uint8_t>& visible) const
{
    std::vector<uint32_t> inside;
    bvh_.cullFrustum(scene::frustumFromViewProj(viewProj), inside);
    visible.assign(scene_.instances.size(), 0);
    for (const uint32_t i : inside) visible[i] = 1;
}

// Of the instances in the view's frustum, the fraction that `kept` keeps.
double Visibility::keptFraction(const glm::mat4& viewProj, const std::vector<uint8_t>& kept) const
{
    std::vector<uint8_t> inFrustum;
    cullFrustum(viewProj, inFrustum);
    const auto framed = double(countMarked(inFrustum));
    return framed > 0.0 ? double(countMarked(kept)) / framed : 0.0;
}

void Visibility::beginFrame(const glm::mat4& cameraViewProj)
{
    if (sceneBvh_.rebuilds != bvhRebuilds_) {
        // The BVH was rebuilt: last frame's visibility no longer names the same nodes.
        cameraHistory_ = {};
        for (auto& [key, view] : lightViews_) view.history = {};
        bvhRebuilds_ = sceneBvh_.rebuilds;
    }
    ++frame_;
    stats_ = {};
    const auto start = std::chrono::steady_clock::now();
    switch (mode_) {
    case config::CullingMode::None: receivers_.assign(scene_.instances.size(), 1); break;
    case config::CullingMode::Frustum: cullFrustum(cameraViewProj, receivers_); break;
    case config::CullingMode::LightOcclusion:
    case config::CullingMode::ReceiverMask: cullCamera(cameraViewProj); break;
    }
    stats_.receivers = uint64_t(countMarked(receivers_));
    stats_.cameraMs = core::msSince(start);
}

// Step 1: the receivers, by occlusion culling of the camera view, which leaves the camera
// depth for focusing and the receiver masks.
void Visibility::cullCamera(const glm::mat4& cameraViewProj)
{
    // As for light views (cullLightView): a view where the last full culling kept most of
    // the frustum's instances (a bird's-eye view) takes its frustum, and is culled in full
    // again every kRecheckFrames frames, on the same frames as the light views. Without
    // the culling pass there is no camera depth, so the receiver masks wait for the next
    // full frame too. Focusing needs the depth on every frame.
    cameraDepthValid_ = false;
    if (!focusing_ && cameraKeptFraction_ > kFallbackKeptFraction && cameraFramesSinceFull_ < kRecheckFrames) {
        cullFrustum(cameraViewProj, receivers_);
        ++cameraFramesSinceFull_;
        stats_.cameraFellBack = 1;
        return;
    }
    OccluderDepth& depth = *cameraDepth_;
    TraversalView view;
    view.viewProj = cameraViewProj;
    view.area = {{0, 0}, {depth.width, depth.height}};
    traversal_->cull(depth, view, cameraHistory_, receivers_, stats_);
    cameraDepthValid_ = true;
    cameraKeptFraction_ = keptFraction(cameraViewProj, receivers_);
    cameraFramesSinceFull_ = 0;
    if (focusing_) computeFocus(cameraViewProj);
    if (masks_) {
        // The receiver masks sample the camera depth.
        context_.submitAndWait([&](VkCommandBuffer cmd) {
            gpu::transition(cmd, depth.image,
                            {depth.layout, gpu::access::kDepthAttachment.stage, gpu::access::kDepthAttachment.access},
                            {VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL, VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT,
                             VK_ACCESS_2_SHADER_SAMPLED_READ_BIT});
        });
        depth.layout = VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL;
        masks_->setCamera(depth.image, cameraViewProj, viewOrigin(cameraViewProj, scene_.bounds().radius()));
    }
}

void Visibility::computeFocus(const glm::mat4& cameraViewProj)
{
    const std::vector<float> depth = gpu::readImageFloats(context_, cameraDepth_->image, cameraDepth_->layout);
    const glm::mat4 inverse = glm::inverse(cameraViewProj);
    focus_ = {};
    for (uint32_t y = 0; y < height_; ++y) {
        for (uint32_t x = 0; x < width_; ++x) {
            const float d = depth[size_t(y) * width_ + x];
            if (!(d > 0.0f)) continue;  // nothing drawn (reversed-Z far is 0)
            // The pixel's corners, not its centre: the whole pixel's footprint stays in.
            for (int corner = 0; corner < 4; ++corner) {
                const glm::vec2 ndc((float(x) + float(corner & 1)) / float(width_) * 2.0f - 1.0f,
                                    (float(y) + float(corner >> 1)) / float(height_) * 2.0f - 1.0f);
                const glm::vec4 world = inverse * glm::vec4(ndc, d, 1.0f);
                if (world.w != 0.0f) focus_.extend(glm::vec3(world) / world.w);
            }
        }
    }
}

void Visibility::countDraw(const render::DrawCounts& counts)
{
    stats_.castersDrawn += counts.instances;
    stats_.trianglesDrawn += counts.triangles;
}

Visibility::CulledLightView& Visibility::culledLightView(const render::CasterView& view)
{
    CulledLightView& culled = lightViews_[{view.light, view.view}];
    if (culled.frame != frame_ || !(culled.culledFor == view)) {
        cullLightView(view, culled);
        culled.frame = frame_;
        culled.culledFor = view;
    }
    return culled;
}

const std::vector<uint8_t>* Visibility::casters(const render::CasterView& view)
{
    if (mode_ == config::CullingMode::None) return nullptr;
    return &culledLightView(view).casters;
}

std::optional<VkRect2D> Visibility::readArea(const render::CasterView& view)
{
    if (mode_ == config::CullingMode::None) return std::nullopt;
    return culledLightView(view).readArea;
}

OccluderDepth& Visibility::lightDepth(uint32_t resolution)
{
    const auto found = lightDepths_.find(resolution);
    if (found != lightDepths_.end()) return found->second;
    return lightDepths_
        .try_emplace(resolution, context_, resolution, resolution, 0, fmt::format("visibility.light{}.depth", resolution))
        .first->second;
}

void Visibility::cullLightView(const render::CasterView& view, CulledLightView& culled)
{
    ++stats_.views;
    const auto start = std::chrono::steady_clock::now();
    culled.readArea.reset();
    if (mode_ == config::CullingMode::Frustum || view.resolution == 0) {
        cullFrustum(view.viewProj, culled.casters);
        stats_.casterCullMs += core::msSince(start);
        return;
    }
    // Culling that cannot pay is skipped: when the last full culling of this view kept
    // most of the instances in its frustum (a bird's-eye view, where the queries cost more
    // than the draws they save), the view takes its frustum's instances, a superset, and
    // is culled in full again every kRecheckFrames frames.
    const bool noMask = masks_ && !cameraDepthValid_;
    if (noMask || (culled.keptFraction > kFallbackKeptFraction && culled.framesSinceFull < kRecheckFrames)) {
        cullFrustum(view.viewProj, culled.casters);
        ++culled.framesSinceFull;
        ++stats_.viewsFellBack;
        stats_.casterCullMs += core::msSince(start);
        return;
    }
    cullLightViewFully(view, culled);
    culled.keptFraction = keptFraction(view.viewProj, culled.casters);
    culled.framesSinceFull = 0;
}

// Steps 2 and 3: the view's receiver mask (receiver-mask mode), then its casters: on the
// CPU against the receiver floor when the view has receiver depths
// (ReceiverFloorCulling.h), otherwise by occlusion culling from the light, behind the
// mask.
void Visibility::cullLightViewFully(const render::CasterView& view, CulledLightView& culled)
{
    auto start = std::chrono::steady_clock::now();
    TraversalView traversal;
    traversal.viewProj = view.viewProj;
    traversal.lightView = true;
    traversal.bias = view.depthBias;
    if (masks_) {
        traversal.mask = &masks_->build(view);
        if (masks_->placement() == ScatterPlacement::Host) ++stats_.masksOnHost;
        culled.readArea = traversal.mask->bounds;
        stats_.maskMs += core::msSince(start);
        start = std::chrono::steady_clock::now();
        if (traversal.mask->hasReceiverDepth) {
            cullBehindReceivers(bvh_, scene_, view.viewProj, view.depthBias, *traversal.mask, culled.casters, stats_);
            stats_.casterCullMs += core::msSince(start);
            return;
        }
    }
    OccluderDepth& depth = lightDepth(view.resolution);
    traversal.area = traversal.mask ? traversal.mask->bounds : VkRect2D{{0, 0}, {depth.width, depth.height}};
    traversal_->cull(depth, traversal, culled.history, culled.casters, stats_);
    stats_.casterCullMs += core::msSince(start);
}

} // namespace penumbra::visibility
