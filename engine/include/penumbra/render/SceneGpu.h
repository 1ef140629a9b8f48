#pragma once
// The scene on the GPU: one vertex buffer, one index buffer, an instance table (model
// matrix, normal matrix, material index), a material table, the base-colour textures,
// and a draw per instance whose firstInstance is the instance index (shaders read
// instances[gl_InstanceIndex]). Draws are grouped by texture so that a pass pushes each
// texture's descriptor once (lavapipe has no descriptor indexing: no bindless arrays).
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/gpu/Resources.h"
#include "penumbra/scene/Scene.h"

#include <functional>
#include <span>
#include <vector>

namespace penumbra::render {

// Which draws a pass wants. Alpha-masked materials need a fragment shader that samples
// alpha; everything else can be drawn depth-only. Blended materials are drawn as opaque
// surfaces by the G-buffer and hard shadows (their translucency is the deep-shadow
// technique's subject).
enum class DrawFilter { All, Solid, AlphaMasked };

// What one draw call of SceneGpu::draw issued.
struct DrawCounts {
    uint64_t instances = 0;
    uint64_t triangles = 0;
};

class SceneGpu {
public:
    SceneGpu(gpu::Context& context, const scene::Scene& scene);
    ~SceneGpu() = default;
    SceneGpu(const SceneGpu&) = delete;
    SceneGpu& operator=(const SceneGpu&) = delete;

    // Re-uploads the instance table after nodes moved (Scene::updateTransforms()).
    void updateInstances(gpu::Context& context, const scene::Scene& scene);

    const gpu::Buffer& instanceBuffer() const { return instances_; }
    const gpu::Buffer& materialBuffer() const { return materials_; }
    VkSampler textureSampler() const { return sampler_; }

    // Binds vertex and index buffers and draws the instances that pass `filter` (and,
    // when `instanceMask` is given, have a non-zero entry in it: one per instance); before
    // each group of draws that share a base-colour texture, calls `bindTexture` (when
    // given) with it (a 1x1 white texture for untextured materials).
    DrawCounts draw(VkCommandBuffer cmd, DrawFilter filter,
                    const std::function<void(const gpu::Image& texture)>& bindTexture = {},
                    const std::vector<uint8_t>* instanceMask = nullptr) const;
    // Draws the given instances (any order, no texture binding) with the bound pipeline:
    // the occlusion-culling passes, which only need positions. Alpha-masked instances are
    // drawn when `alphaMasked` is true, solid ones otherwise.
    DrawCounts drawInstances(VkCommandBuffer cmd, std::span<const uint32_t> instances, bool alphaMasked) const;
    bool hasAlphaMasked() const;
    bool isAlphaMasked(uint32_t instance) const { return instanceAlphaMasked_.at(instance) != 0; }

    uint32_t vertexStride() const { return sizeof(scene::Vertex); }
    size_t triangleCount() const { return triangles_; }

private:
    struct Draw {
        uint32_t indexCount;
        uint32_t firstIndex;
        int32_t vertexOffset;
        uint32_t instance;
        uint32_t texture;  // index into textures_ (the last one is the white default)
        bool alphaMasked;
    };
    gpu::Buffer vertices_;
    gpu::Buffer indices_;
    gpu::Buffer instances_;
    gpu::Buffer instanceStaging_;  // reused by every updateInstances (animated frames)
    gpu::Buffer materials_;
    std::vector<gpu::Image> textures_;
    gpu::Sampler sampler_;
    static constexpr uint32_t kNoDraw = UINT32_MAX;
    void bindGeometry(VkCommandBuffer cmd) const;
    std::vector<Draw> draws_;  // sorted by texture
    std::vector<uint32_t> instanceDraw_;        // instance -> index into draws_ (kNoDraw: no triangles)
    std::vector<uint8_t> instanceAlphaMasked_;  // instance -> its material is alpha-masked
    size_t triangles_ = 0;
};

} // namespace penumbra::render
