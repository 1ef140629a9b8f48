#pragma once
// The caster interface: the only way a shadow technique draws scene geometry. A
// technique asks for "the casters of this light seen through this light-view
// projection" and the engine draws them; the engine's visibility service
// (engine/src/visibility/: frustum, light-space occlusion and receiver-mask culling, per
// the config's "culling") decides which casters that is, for every technique at once, so
// that no plugin implements culling itself.
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/render/SceneGpu.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace penumbra::render {

// The rasterizer's depth bias of a shadow map, positive "away from the light" (a depth
// pass negates it for reversed-Z).
struct ShadowDepthBias {
    float constant = 0.0f;  // in Vulkan's minimum resolvable depth differences r
    float slope = 0.0f;     // times the caster's depth slope
    float clamp = 0.0f;     // largest bias in NDC depth; 0: no clamp
    bool operator==(const ShadowDepthBias&) const = default;
};

// One light view that casters are drawn into: a shadow map, a cube face, a sub-light.
struct CasterView {
    glm::mat4 viewProj{1.0f};  // world -> the view's clip space (reversed-Z)
    uint32_t light = 0;        // the light's index in the config
    uint32_t view = 0;         // the technique's index for this view (cube face, sub-light)
    // Texels per side of the square viewport the view is drawn into. The culling passes
    // rasterise at exactly this resolution, so that a caster they find covering no texel
    // centre covers none in the technique's map either. 0: unknown; the view is then
    // culled against its frustum only.
    uint32_t resolution = 0;
    // How far, in texels of this view, the technique's lookups for one receiver point
    // reach beyond the texel the point projects to (filter kernel, blocker search, blur,
    // normal offset). Receiver-mask culling keeps every caster that covers a texel within
    // this distance of a visible receiver. kWholeView: lookups may reach anywhere (mip
    // chains), so the mask covers the whole view.
    float footprintTexels = 0.0f;
    static constexpr float kWholeView = 1e30f;

    // The rasterizer depth bias of the technique's map (render::ShadowMap's depth pass).
    // Light-view culling draws with exactly this bias, so that its depth is the map's.
    ShadowDepthBias depthBias;
    // When every lookup compares a texel's stored depth with the receiver point's own
    // depth (a nearest, PCF or Poisson compare, or PCSS's search and filter, with the
    // rasterizer's constant or slope-scaled bias and no receiver-side bias): the texels,
    // in a square around the one the receiver point projects to, that its lookups read.
    // A caster fragment then matters only where, after the bias, it lies in front of a
    // receiver point whose lookups read its texel, and receiver-mask culling keeps only
    // such fragments: a lit receiver that shadows nothing the camera sees is not drawn
    // (docs/culling.md). -1: the lookups do something else (moments, receiver planes,
    // normal offsets), so only the receiver mask applies.
    int32_t compareTapRadius = -1;

    bool operator==(const CasterView&) const = default;
};

// Private to the engine (engine/src/render/CasterCulling.h): its visibility service.
class CasterCulling;

// The render-graph state (graph::PassBuilder::dependsOn) of light `light` as its casters
// see it: "light0". The engine gives it a new version whenever what a caster pass of the
// light draws may change: the light, the scene's bounds (frusta are fitted to them), an
// instance moving into, inside or out of a view the light's casters were drawn in, and,
// where the casters drawn depend on the camera (receiver-mask culling, focusing), the
// camera. A pass that depends on it and on nothing else of the frame (a shadow map, its
// moments, its summed-area table) is kept while it has the same version.
std::string lightState(uint32_t light);
// The render-graph state of the camera and what it sees: a new version whenever the
// camera moves or an instance moves into, inside or out of its view. Passes over the
// G-buffer (a visibility pass) depend on it.
inline constexpr const char* kCameraState = "camera";

class Casters {
public:
    explicit Casters(const SceneGpu& scene) : scene_(&scene) {}

    // The engine's visibility service, which narrows every draw to the casters that can
    // shadow a visible receiver; none (tests, tools): every caster is drawn.
    void setCulling(CasterCulling* culling) { culling_ = culling; }

    // Binds the scene's vertex and index buffers and draws the casters for `view` that
    // pass `filter`; before each group of draws that share a base-colour texture it calls
    // `bindTexture` (when given), so that alpha-masked casters can cut their holes. The
    // technique's pipeline must be bound, with instanceBuffer() at its instance binding.
    void draw(VkCommandBuffer cmd, const CasterView& view, DrawFilter filter,
              const std::function<void(const gpu::Image& texture)>& bindTexture = {}) const;

    bool hasAlphaMasked() const { return scene_->hasAlphaMasked(); }

    // The texels of `view` that this frame's receivers can read through the view's
    // footprint (CasterView::footprintTexels), in view texels: with receiver-mask culling
    // the bounds of the view's dilated receiver mask; nullopt (any texel) otherwise. A
    // depth pass whose map nothing else reads clears and draws only there
    // (render::ShadowMap::setReadByLookupsOnly).
    std::optional<VkRect2D> readArea(const CasterView& view) const;
    // Counts the texels a caster pass cleared and drew into, for the frame's figures
    // (visibility::CullingStats::mapTexelsRendered).
    void countRenderedTexels(uint64_t texels) const;

    // The box of what the camera sees this frame when the config asks for shadow-map
    // focusing ("shadow_focus"), else null: render::ShadowMap fits directional lights'
    // maps to it.
    const scene::Aabb* focus() const;

    // What caster pipelines bind: the instance table (shaders/common/scene.glsl
    // InstanceData, read as instances[gl_InstanceIndex]), the material table, the
    // base-colour texture sampler.
    const gpu::Buffer& instanceBuffer() const { return scene_->instanceBuffer(); }
    const gpu::Buffer& materialBuffer() const { return scene_->materialBuffer(); }
    VkSampler textureSampler() const { return scene_->textureSampler(); }

    // Vertex input for caster pipelines: position only (location 0), or position and
    // texture coordinates (location 2) for alpha-masked casters.
    gpu::VertexLayout positionLayout() const;
    gpu::VertexLayout positionUvLayout() const;

    size_t triangleCount() const { return scene_->triangleCount(); }

    // The views that draw() drew casters for since the last call (each once): the engine
    // tests moved instances against them to know which lights' casters changed.
    std::vector<CasterView> takeDrawnViews();

private:
    const SceneGpu* scene_;
    CasterCulling* culling_ = nullptr;
    mutable std::vector<CasterView> drawnViews_;
};

} // namespace penumbra::render
