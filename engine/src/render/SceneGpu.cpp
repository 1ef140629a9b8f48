#include "penumbra/render/SceneGpu.h"

#include "penumbra/core/Error.h"
#include "penumbra/gpu/Context.h"
#include "penumbra/gpu/Pipeline.h"

#include <glm/gtc/matrix_inverse.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <span>

namespace penumbra::render {
namespace {

struct InstanceData {  // matches shaders/common/scene.glsl
    glm::mat4 model;
    glm::mat4 normalMatrix;
    glm::uvec4 info;  // x: material index
};

struct MaterialData {  // matches shaders/common/scene.glsl
    glm::vec4 baseColor;
    float alphaCutoff;
    uint32_t alphaMode;  // 0 opaque, 1 mask, 2 blend
    uint32_t pad0, pad1;
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
        table.push_back({model, glm::inverseTranspose(model), glm::uvec4(scene.meshes.at(inst.mesh).material, 0, 0, 0)});
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
    // Textures as sRGB images (glTF's base colour is sRGB-encoded: sampling returns
    // linear values); the white default comes last.
    for (const scene::Texture& t : scene.textures) {
        textures_.push_back(gpu::uploadImage(context, t.width, t.height, VK_FORMAT_R8G8B8A8_SRGB,
                                             std::as_bytes(std::span<const uint8_t>(t.rgba)), "texture " + t.name));
    }
    const std::vector<uint8_t> white = {255, 255, 255, 255};
    textures_.push_back(gpu::uploadImage(context, 1, 1, VK_FORMAT_R8G8B8A8_SRGB,
                                         std::as_bytes(std::span<const uint8_t>(white)), "texture white"));
    const auto defaultTexture = static_cast<uint32_t>(textures_.size() - 1);

    std::vector<MaterialData> materials;
    for (const scene::Material& m : scene.materials) {
        if (m.baseColorTexture != scene::kNoTexture && size_t(m.baseColorTexture) >= scene.textures.size()) {
            throw Error(fmt::format("material '{}': texture {} does not exist", m.name, m.baseColorTexture));
        }
        materials.push_back({m.baseColor, m.alphaCutoff, static_cast<uint32_t>(m.alphaMode), 0, 0});
    }
    for (uint32_t i = 0; i < scene.instances.size(); ++i) {
        const scene::Mesh& mesh = scene.meshes.at(scene.instances[i].mesh);
        const scene::Material& m = scene.materials.at(mesh.material);
        const Range& r = ranges.at(scene.instances[i].mesh);
        if (r.indexCount > 0) {
            const uint32_t texture = m.baseColorTexture == scene::kNoTexture ? defaultTexture : uint32_t(m.baseColorTexture);
            draws_.push_back({r.indexCount, r.firstIndex, r.vertexOffset, i, texture, m.alphaMode == scene::AlphaMode::Mask});
            triangles_ += r.indexCount / 3;
        }
    }
    std::stable_sort(draws_.begin(), draws_.end(), [](const Draw& a, const Draw& b) { return a.texture < b.texture; });
    instanceDraw_.assign(scene.instances.size(), kNoDraw);
    instanceAlphaMasked_.assign(scene.instances.size(), 0);
    for (uint32_t d = 0; d < draws_.size(); ++d) {
        instanceDraw_[draws_[d].instance] = d;
        instanceAlphaMasked_[draws_[d].instance] = draws_[d].alphaMasked ? 1 : 0;
    }
    if (vertices.empty() || indices.empty()) {
        throw Error("scene has no triangles: nothing to render");
    }
    vertices_ = gpu::uploadBuffer(context, bytesOf(vertices), VK_BUFFER_USAGE_VERTEX_BUFFER_BIT, "scene vertices");
    indices_ = gpu::uploadBuffer(context, bytesOf(indices), VK_BUFFER_USAGE_INDEX_BUFFER_BIT, "scene indices");
    instances_ = gpu::uploadBuffer(context, bytesOf(instanceTable(scene)), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                   "scene instances");
    materials_ = gpu::uploadBuffer(context, bytesOf(materials), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "scene materials");
    sampler_ = gpu::createSampler(context, VK_FILTER_LINEAR, VK_SAMPLER_ADDRESS_MODE_REPEAT);
}

bool SceneGpu::hasAlphaMasked() const
{
    return std::any_of(draws_.begin(), draws_.end(), [](const Draw& d) { return d.alphaMasked; });
}

void SceneGpu::updateInstances(gpu::Context& context, const scene::Scene& scene)
{
    gpu::updateBuffer(context, instances_, bytesOf(instanceTable(scene)), &instanceStaging_);
}

void SceneGpu::bindGeometry(VkCommandBuffer cmd) const
{
    const VkDeviceSize offset = 0;
    const VkBuffer vb = vertices_.handle();
    vkCmdBindVertexBuffers(cmd, 0, 1, &vb, &offset);
    vkCmdBindIndexBuffer(cmd, indices_.handle(), 0, VK_INDEX_TYPE_UINT32);
}

DrawCounts SceneGpu::draw(VkCommandBuffer cmd, DrawFilter filter,
                          const std::function<void(const gpu::Image& texture)>& bindTexture,
                          const std::vector<uint8_t>* instanceMask) const
{
    if (instanceMask && instanceMask->size() != instanceDraw_.size()) {
        throw Error(fmt::format("SceneGpu::draw: an instance mask of {} entries for {} instances", instanceMask->size(),
                                instanceDraw_.size()));
    }
    bindGeometry(cmd);
    DrawCounts counts;
    uint32_t bound = UINT32_MAX;
    for (const Draw& d : draws_) {
        if ((filter == DrawFilter::Solid && d.alphaMasked) || (filter == DrawFilter::AlphaMasked && !d.alphaMasked)) {
            continue;
        }
        if (instanceMask && !(*instanceMask)[d.instance]) continue;
        if (bindTexture && d.texture != bound) {
            bindTexture(textures_[d.texture]);
            bound = d.texture;
        }
        vkCmdDrawIndexed(cmd, d.indexCount, 1, d.firstIndex, d.vertexOffset, d.instance);
        counts.instances += 1;
        counts.triangles += d.indexCount / 3;
    }
    return counts;
}

DrawCounts SceneGpu::drawInstances(VkCommandBuffer cmd, std::span<const uint32_t> instances, bool alphaMasked) const
{
    bindGeometry(cmd);
    DrawCounts counts;
    for (const uint32_t instance : instances) {
        const uint32_t index = instanceDraw_.at(instance);
        if (index == kNoDraw) continue;
        const Draw& d = draws_[index];
        if (d.alphaMasked != alphaMasked) continue;
        vkCmdDrawIndexed(cmd, d.indexCount, 1, d.firstIndex, d.vertexOffset, d.instance);
        counts.instances += 1;
        counts.triangles += d.indexCount / 3;
    }
    return counts;
}

} // namespace penumbra::render
