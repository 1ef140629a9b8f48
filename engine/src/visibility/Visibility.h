#pragma once
// The visibility service (DESIGN.md "visibility"; Mattausch, Bittner, Silvennoinen,
// Scherzer, Wimmer, "Efficient Online Visibility for Shadow Maps",
// ../shared/papers/online-visibility-for-shadow-maps.txt): which instances the camera
// sees, and which casters each light view must draw so that every visible receiver gets
// the shadow it would get with every caster drawn. Plugins never see it: render::Casters
// asks it for the casters of each CasterView (render/CasterCulling.h).
//
// Modes (config "culling"):
//   none             every instance, everywhere
//   frustum          camera and light views: instances whose box meets the view frustum
//   light-occlusion  camera: hierarchical occlusion culling (OcclusionTraversal.h); light views: the same
//                    occlusion culling from the light (the paper's REF)
//   receiver-mask    camera: hierarchical occlusion culling; light views: the texels that
//                    camera pixels see are marked in a receiver mask (the reverse shadow
//                    test, done from the camera's side: each pixel unprojected from the
//                    camera depth marks its texel), the mask is dilated by the view's
//                    footprint, and casters are kept only where a hierarchical occlusion
//                    query that discards fragments outside the mask finds samples in
//                    front of what the traversal drew (the paper's method, steps 1-3;
//                    docs/culling.md says where and why this differs from the paper).
//                    Light views draw with the technique's own bias, and keep a leaf only
//                    when its draw finds samples. A view whose technique compares with the
//                    receivers' own depth (CasterView::compareTapRadius) also gets the
//                    receivers' depths per texel, and is culled on the CPU instead, without
//                    a query: an instance is kept only where it lies in front of a receiver
//                    depth after the technique's bias (ReceiverFloorCulling.h): lit
//                    receivers that shadow nothing are not drawn.
//
// This file is the policy: the modes, the camera's and each light view's culling per
// frame (a light view is culled on its first draw of the frame and keeps its list for the
// frame), the fall-back to the frustum where culling cannot pay, and shadow-map focusing.
// The traversal is OcclusionTraversal.h, the receiver mask ReceiverMask.h.
#include "penumbra/config/Config.h"
#include "penumbra/render/Casters.h"
#include "penumbra/render/SceneGpu.h"
#include "penumbra/scene/Bvh.h"
#include "penumbra/scene/Scene.h"
#include "penumbra/visibility/CullingStats.h"
#include "render/CasterCulling.h"
#include "visibility/OcclusionTraversal.h"
#include "visibility/ReceiverMask.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <utility>
#include <vector>

namespace penumbra::gpu {
class Context;
class ShaderCompiler;
} // namespace penumbra::gpu

namespace penumbra::visibility {

// The scene's instance BVH, one for every visibility service made over the scene (one per
// output size, culling mode and focusing: frame::SceneResources): built once, refit where
// instances move. `rebuilds` counts the times its nodes were numbered anew, which ends
// what a service remembers of them.
struct SceneBvh {
    explicit SceneBvh(const scene::Scene& scene);
    // Instances moved (Scene::updateTransforms): refits, or rebuilds when refitting costs
    // too much.
    void instancesMoved(const scene::Scene& scene, std::span<const uint32_t> moved);

    scene::InstanceBvh bvh;
    uint64_t rebuilds = 0;
};

class Visibility final : public render::CasterCulling {
public:
    // `scene`, `sceneGpu` and `bvh` (the scene's) must outlive the service; `width` x
    // `height` is the camera's output. `focus`: compute the box of what the camera sees every frame (focus()); needs an
    // occlusion mode, whose camera pass leaves the camera depth.
    Visibility(gpu::Context& context, const gpu::ShaderCompiler& shaders, const scene::Scene& scene,
               const render::SceneGpu& sceneGpu, const SceneBvh& bvh, config::CullingMode mode, uint32_t width,
               uint32_t height, bool focus = false);
    ~Visibility();
    Visibility(const Visibility&) = delete;
    Visibility& operator=(const Visibility&) = delete;

    config::CullingMode mode() const { return mode_; }

    // Starts a frame: forgets the last frame's caster lists and culls the camera view.
    void beginFrame(const glm::mat4& cameraViewProj);

    // The instances the camera sees, one entry per instance (non-zero: visible), or null
    // for all (mode none).
    const std::vector<uint8_t>* receivers() const { return mode_ == config::CullingMode::None ? nullptr : &receivers_; }

    // The casters `view` must draw this frame, or null for all. Culls the view on its
    // first call in the frame and keeps the list for the frame.
    const std::vector<uint8_t>* casters(const render::CasterView& view) override;
    // The bounds of the view's dilated receiver mask when it was culled with one this
    // frame (receiver-mask mode, the view not fallen back to its frustum); else nullopt.
    std::optional<VkRect2D> readArea(const render::CasterView& view) override;
    void countDraw(const render::DrawCounts& counts) override;
    void countRenderedTexels(uint64_t texels) override { stats_.mapTexelsRendered += texels; }

    // Shadow-map focusing (Mattausch et al. §1.4): the world box of every point the camera
    // sees this frame (camera pixels unprojected from the camera depth), which lies in the
    // view frustum by construction: the paper's "view frustum intersected with the
    // visible objects' boxes", tightened to the visible surfaces. Null when focusing is
    // off or the camera sees nothing.
    const scene::Aabb* focus() const override { return focusing_ && !focus_.empty() ? &focus_ : nullptr; }
    bool focusing() const { return focusing_; }

    // This frame's figures so far.
    const CullingStats& stats() const { return stats_; }

private:
    // One light view across frames: the CasterView it was last culled for and in which
    // frame, its traversal history, its caster list, and whether culling it pays.
    struct CulledLightView {
        uint64_t frame = UINT64_MAX;
        render::CasterView culledFor;
        NodeHistory history;
        std::vector<uint8_t> casters;
        std::optional<VkRect2D> readArea;  // the receiver mask's bounds, when culled with one
        double keptFraction = 0.0;     // of the frustum's instances, at the last full culling
        uint32_t framesSinceFull = 0;  // frames culled to the frustum since then
    };

    void cullFrustum(const glm::mat4& viewProj, std::vector<uint8_t>& visible) const;
    double keptFraction(const glm::mat4& viewProj, const std::vector<uint8_t>& kept) const;
    void cullCamera(const glm::mat4& cameraViewProj);
    void computeFocus(const glm::mat4& cameraViewProj);
    // The view's entry, culled for this frame.
    CulledLightView& culledLightView(const render::CasterView& view);
    void cullLightView(const render::CasterView& view, CulledLightView& culled);
    void cullLightViewFully(const render::CasterView& view, CulledLightView& culled);
    OccluderDepth& lightDepth(uint32_t resolution);

    gpu::Context& context_;
    const scene::Scene& scene_;
    const config::CullingMode mode_;
    const uint32_t width_;
    const uint32_t height_;
    const SceneBvh& sceneBvh_;
    const scene::InstanceBvh& bvh_;  // sceneBvh_.bvh
    uint64_t bvhRebuilds_ = 0;       // sceneBvh_.rebuilds when the histories last named its nodes
    // Occlusion modes: the traversal and the depth it draws into, the camera's and one per
    // light-view resolution; receiver-mask mode: the masks.
    std::unique_ptr<OcclusionTraversal> traversal_;
    std::optional<OccluderDepth> cameraDepth_;
    std::map<uint32_t, OccluderDepth> lightDepths_;
    std::unique_ptr<ReceiverMaskBuilder> masks_;

    NodeHistory cameraHistory_;
    bool cameraDepthValid_ = false;       // this frame's camera culling left the camera depth
    double cameraKeptFraction_ = 0.0;     // of the frustum's instances, at the last full culling
    uint32_t cameraFramesSinceFull_ = 0;
    std::vector<uint8_t> receivers_;
    std::map<std::pair<uint32_t, uint32_t>, CulledLightView> lightViews_;  // by (light, view)
    uint64_t frame_ = 0;
    CullingStats stats_;
    const bool focusing_;
    scene::Aabb focus_;
};

} // namespace penumbra::visibility
