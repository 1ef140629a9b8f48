#pragma once
// The caster interface: the only way a shadow technique draws scene geometry. A
// technique asks for "the casters of this light seen through this light-view
// projection" and the engine draws them; the visibility service (issue 6: frustum,
// light-space occlusion and receiver-mask culling) decides which casters that is, for
// every technique at once, so that no plugin implements culling itself.
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/render/SceneGpu.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <functional>

namespace penumbra::render {

// One light view that casters are drawn into: a shadow map, a cube face, a sub-light.
struct CasterView {
    glm::mat4 viewProj{1.0f};  // world -> the view's clip space (reversed-Z)
    uint32_t light = 0;        // the light's index in the config
    uint32_t view = 0;         // the technique's index for this view (cube face, sub-light)
};

class Casters {
public:
    explicit Casters(const SceneGpu& scene) : scene_(&scene) {}

    // Binds the scene's vertex and index buffers and draws the casters for `view` that
    // pass `filter`; before each group of draws that share a base-colour texture it calls
    // `bindTexture` (when given), so that alpha-masked casters can cut their holes. The
    // technique's pipeline must be bound, with instanceBuffer() at its instance binding.
    void draw(VkCommandBuffer cmd, const CasterView& view, DrawFilter filter,
              const std::function<void(const gpu::Image& texture)>& bindTexture = {}) const;

    bool hasAlphaMasked() const { return scene_->hasAlphaMasked(); }

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

private:
    const SceneGpu* scene_;
};

} // namespace penumbra::render
