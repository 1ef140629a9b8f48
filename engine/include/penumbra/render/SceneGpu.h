#pragma once
// The scene on the GPU: one vertex buffer, one index buffer, an instance table (model
// matrix, normal matrix, material index), a material table and the base-colour textures.
// Draws are batched (render/DrawBatches.h): the table's rows are ordered by (texture,
// mesh, instance), consecutive instances of a mesh are one instanced command whose
// firstInstance is the first one's row (shaders read instances[gl_InstanceIndex]), and
// the commands of one texture are one indirect multi-draw, so that a pass pushes each
// texture's descriptor once (lavapipe has no descriptor indexing: no bindless arrays).
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/gpu/Resources.h"
#include "penumbra/scene/Scene.h"

#include <functional>
#include <memory>
#include <span>
#include <vector>

namespace penumbra::render {

// Which draws a pass wants. Alpha-masked materials need a fragment shader that samples
// alpha; everything else can be drawn depth-only. Blended materials are drawn as opaque
// surfaces by the G-buffer and hard shadows (their translucency is the deep-shadow
// technique's subject): Solid is every material that is not alpha-masked, Opaque leaves
// the blended (translucent) ones out too.
enum class DrawFilter { All, Solid, AlphaMasked, Opaque };

// What one call of SceneGpu::draw or drawInstances drew: instances and triangles (as
// many as one draw per instance would), and the vkCmdDraw* calls that took.
struct DrawCounts {
    uint64_t instances = 0;
    uint64_t triangles = 0;
    uint64_t drawCalls = 0;
};

// Batched: instanced, indirect multi-draws (the default). PerInstance: one vkCmdDrawIndexed
// per instance, the reference batching is checked and measured against.
enum class DrawBatching { Batched, PerInstance };

class DrawBatches;           // engine/src/render/DrawBatches.h
struct DrawBatch;            // engine/src/render/DrawBatches.h
class IndirectCommandArena;  // engine/src/render/IndirectCommandArena.h

class SceneGpu {
public:
    SceneGpu(gpu::Context& context, const scene::Scene& scene, DrawBatching batching = DrawBatching::Batched);
    ~SceneGpu();
    SceneGpu(const SceneGpu&) = delete;
    SceneGpu& operator=(const SceneGpu&) = delete;

    // Re-uploads the instance table after nodes moved (Scene::updateTransforms()).
    void updateInstances(gpu::Context& context, const scene::Scene& scene);

    // The draws' indirect commands live in host-visible buffers until the next call:
    // call it before recording a frame, once the device has finished every command buffer
    // recorded with earlier draws (frame::FrameRenderer does, at the start of each frame:
    // GraphExecutor::execute waits for its frame).
    void beginFrame();

    const gpu::Buffer& instanceBuffer() const { return instances_; }
    const gpu::Buffer& materialBuffer() const { return materials_; }
    VkSampler textureSampler() const { return sampler_; }
    // Whether `texture` (as draw() hands it to bindTexture) is the white 1x1 default of
    // untextured materials, whose sample is exactly 1: a pass may skip the sample.
    bool isUntextured(const gpu::Image& texture) const { return &texture == &textures_.back(); }

    // Binds vertex and index buffers and draws the instances that pass `filter` (and,
    // when `instanceMask` is given, have a non-zero entry in it: one per instance); before
    // each group of draws that share a base-colour texture, calls `bindTexture` (when
    // given) with it (a 1x1 white texture for untextured materials). Without
    // `bindTexture` every texture's draws are one group.
    DrawCounts draw(VkCommandBuffer cmd, DrawFilter filter,
                    const std::function<void(const gpu::Image& texture)>& bindTexture = {},
                    const std::vector<uint8_t>* instanceMask = nullptr) const;
    // Draws the given instances (any order, no texture binding) with the bound pipeline:
    // the occlusion-culling passes, which only need positions. See-through instances
    // (alpha-masked or translucent materials: light passes them in places, so they must
    // never occlude) are drawn when `seeThrough` is true, opaque ones otherwise.
    DrawCounts drawInstances(VkCommandBuffer cmd, std::span<const uint32_t> instances, bool seeThrough) const;
    bool hasAlphaMasked() const;
    bool isAlphaMasked(uint32_t instance) const;

    uint32_t vertexStride() const { return sizeof(scene::Vertex); }
    size_t triangleCount() const { return triangles_; }
    DrawBatching batching() const { return batching_; }

private:
    gpu::Buffer vertices_;
    gpu::Buffer indices_;
    gpu::Buffer instances_;
    gpu::Buffer instanceStaging_;  // reused by every updateInstances (animated frames)
    gpu::Buffer materials_;
    std::vector<gpu::Image> textures_;
    gpu::Sampler sampler_;
    void bindGeometry(VkCommandBuffer cmd) const;
    DrawCounts record(VkCommandBuffer cmd, const std::function<void(const gpu::Image& texture)>& bindTexture) const;
    DrawBatching batching_;
    // Indirect multi-draws with a non-zero firstInstance (device features); else each
    // command is a direct instanced draw.
    bool multiDrawIndirect_ = false;
    uint32_t maxDrawIndirectCount_ = 1;
    std::unique_ptr<DrawBatches> batches_;
    // A draw's commands, rebuilt by each draw (recording is single-threaded), and the
    // frame's indirect buffers: capacity kept across frames, nothing allocated per draw.
    std::unique_ptr<DrawBatch> scratch_;
    std::unique_ptr<IndirectCommandArena> arena_;
    size_t triangles_ = 0;
};

} // namespace penumbra::render
