#include "penumbra/render/SceneGpu.h"

#include "penumbra/core/Error.h"

#include <glm/gtc/matrix_inverse.hpp>

#include <span>

namespace penumbra::render {
namespace {

struct InstanceData {  // matches shaders/common/scene.glsl
    glm::mat4 model;
    glm::mat4 normalMatrix;
    glm::vec4 baseColor;
};

template <class T>
std::span<const std::byte> bytesOf(const std::vector<T>& v)
{
    return std::as_bytes(std::span<const T>(v));
}

std::vector<InstanceData> instanceTable(const scene::Scene& scene)
{
    std::vector<InstanceData> table;
    table.reserve(scene.instances.size());
    for (const scene::Instance& inst : scene.instances) {
        const glm::mat4& model = scene.instanceTransform(inst);
        const scene::Material& material = scene.materials.at(scene.meshes.at(inst.mesh).material);
        table.push_back({model, glm::inverseTranspose(model), material.baseColor});
    }
    return table;
}

} // namespace

SceneGpu::SceneGpu(gpu::Context& context, const scene::Scene& scene)
{
    if (scene.instances.empty()) {
        throw Error("scene has no instances: nothing to render");
    }
    std::vector<scene::Vertex> vertices;
    std::vector<uint32_t> indices;
    struct Range {
        uint32_t firstIndex, indexCount;
        int32_t vertexOffset;
    };
    std::vector<Range> ranges;
    for (const scene::Mesh& mesh : scene.meshes) {
        ranges.push_back({static_cast<uint32_t>(indices.size()), static_cast<uint32_t>(mesh.indices.size()),
                          static_cast<int32_t>(vertices.size())});
        vertices.insert(vertices.end(), mesh.vertices.begin(), mesh.vertices.end());
        indices.insert(indices.end(), mesh.indices.begin(), mesh.indices.end());
    }
    for (uint32_t i = 0; i < scene.instances.size(); ++i) {
        const Range& r = ranges.at(scene.instances[i].mesh);
        if (r.indexCount > 0) {
            draws_.push_back({r.indexCount, r.firstIndex, r.vertexOffset, i});
            triangles_ += r.indexCount / 3;
        }
    }
    if (vertices.empty() || indices.empty()) {
        throw Error("scene has no triangles: nothing to render");
    }
    vertices_ = gpu::uploadBuffer(context, bytesOf(vertices), VK_BUFFER_USAGE_VERTEX_BUFFER_BIT, "scene vertices");
    indices_ = gpu::uploadBuffer(context, bytesOf(indices), VK_BUFFER_USAGE_INDEX_BUFFER_BIT, "scene indices");
    instances_ = gpu::uploadBuffer(context, bytesOf(instanceTable(scene)), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                   "scene instances");
}

void SceneGpu::updateInstances(gpu::Context& context, const scene::Scene& scene)
{
    gpu::updateBuffer(context, instances_, bytesOf(instanceTable(scene)));
}

void SceneGpu::drawAll(VkCommandBuffer cmd) const
{
    const VkDeviceSize offset = 0;
    const VkBuffer vb = vertices_.handle();
    vkCmdBindVertexBuffers(cmd, 0, 1, &vb, &offset);
    vkCmdBindIndexBuffer(cmd, indices_.handle(), 0, VK_INDEX_TYPE_UINT32);
    for (const Draw& d : draws_) {
        vkCmdDrawIndexed(cmd, d.indexCount, 1, d.firstIndex, d.vertexOffset, d.instance);
    }
}

} // namespace penumbra::render
