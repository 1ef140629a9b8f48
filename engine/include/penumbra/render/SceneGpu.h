#pragma once
// The scene's geometry on the GPU: one vertex buffer, one index buffer, one instance
// table (model matrix, normal matrix, material), and a draw per instance whose
// firstInstance is the instance index (shaders read instances[gl_InstanceIndex]).
#include "penumbra/gpu/Resources.h"
#include "penumbra/scene/Scene.h"

#include <vector>

namespace penumbra::render {

class SceneGpu {
public:
    SceneGpu(gpu::Context& context, const scene::Scene& scene);

    // Re-uploads the instance table after nodes moved (Scene::updateTransforms()).
    void updateInstances(gpu::Context& context, const scene::Scene& scene);

    const gpu::Buffer& instanceBuffer() const { return instances_; }
    // Binds vertex and index buffers and draws every instance.
    void drawAll(VkCommandBuffer cmd) const;
    uint32_t vertexStride() const { return sizeof(scene::Vertex); }
    size_t triangleCount() const { return triangles_; }

private:
    struct Draw {
        uint32_t indexCount;
        uint32_t firstIndex;
        int32_t vertexOffset;
        uint32_t instance;
    };
    gpu::Buffer vertices_;
    gpu::Buffer indices_;
    gpu::Buffer instances_;
    std::vector<Draw> draws_;
    size_t triangles_ = 0;
};

} // namespace penumbra::render
