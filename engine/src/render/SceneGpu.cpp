#include "penumbra/render/SceneGpu.h"

#include "penumbra/core/Error.h"
#include "penumbra/gpu/Context.h"
#include "penumbra/gpu/Pipeline.h"

#include "render/DrawBatches.h"
#include "render/IndirectCommandArena.h"

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

// One row per slot (DrawBatches: ordered by texture, mesh, instance).
std::vector<InstanceData> instanceTable(const scene::Scene& scene, const DrawBatches& batches)
{
    std::vector<InstanceData> table;
    table.reserve(batches.slotInstances().size());
    for (const uint32_t instance : batches.slotInstances()) {
        const scene::Instance& inst = scene.instances.at(instance);
        const glm::mat4& model = scene.instanceTransform(inst);
        table.push_back({model, glm::inverseTranspose(model), glm::uvec4(scene.meshes.at(inst.mesh).material, 0, 0, 0)});
    }
    return table;
}

// Indirect commands per arena buffer (20 bytes each): the first buffer holds a small
// scene's whole frame; larger frames add buffers once.
constexpr uint32_t kIndirectCommandsPerBuffer = 16384;

} // namespace

SceneGpu::SceneGpu(gpu::Context& context, const scene::Scene& scene, DrawBatching batching)
    : batching_(batching),
      multiDrawIndirect_(context.enabledFeatures().multiDrawIndirect && context.enabledFeatures().drawIndirectFirstInstance),
      maxDrawIndirectCount_(std::max(context.properties().limits.maxDrawIndirectCount, 1u))
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
    std::vector<MeshRange> meshRanges;
    for (size_t m = 0; m < scene.meshes.size(); ++m) {
        const scene::Material& material = scene.materials.at(scene.meshes[m].material);
        const uint32_t texture =
            material.baseColorTexture == scene::kNoTexture ? defaultTexture : uint32_t(material.baseColorTexture);
        meshRanges.push_back({ranges[m].indexCount, ranges[m].firstIndex, ranges[m].vertexOffset, texture,
                              material.alphaMode == scene::AlphaMode::Mask,
                              material.alphaMode != scene::AlphaMode::Opaque});
    }
    std::vector<uint32_t> instanceMesh;
    for (const scene::Instance& inst : scene.instances) {
        instanceMesh.push_back(inst.mesh);
        triangles_ += meshRanges.at(inst.mesh).indexCount / 3;
    }
    batches_ = std::make_unique<DrawBatches>(instanceMesh, meshRanges, batching == DrawBatching::PerInstance);
    scratch_ = std::make_unique<DrawBatch>();
    arena_ = std::make_unique<IndirectCommandArena>(context, kIndirectCommandsPerBuffer);
    if (vertices.empty() || indices.empty() || batches_->slotInstances().empty()) {
        throw Error("scene has no triangles: nothing to render");
    }
    vertices_ = gpu::uploadBuffer(context, bytesOf(vertices), VK_BUFFER_USAGE_VERTEX_BUFFER_BIT, "scene vertices");
    indices_ = gpu::uploadBuffer(context, bytesOf(indices), VK_BUFFER_USAGE_INDEX_BUFFER_BIT, "scene indices");
    instances_ = gpu::uploadBuffer(context, bytesOf(instanceTable(scene, *batches_)), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                   "scene instances");
    materials_ = gpu::uploadBuffer(context, bytesOf(materials), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "scene materials");
    sampler_ = gpu::createSampler(context, VK_FILTER_LINEAR, VK_SAMPLER_ADDRESS_MODE_REPEAT);
}

SceneGpu::~SceneGpu() = default;

bool SceneGpu::hasAlphaMasked() const { return batches_->hasAlphaMasked(); }

bool SceneGpu::isAlphaMasked(uint32_t instance) const { return batches_->isAlphaMasked(instance); }

void SceneGpu::beginFrame() { arena_->beginFrame(); }

void SceneGpu::updateInstances(gpu::Context& context, const scene::Scene& scene)
{
    gpu::updateBuffer(context, instances_, bytesOf(instanceTable(scene, *batches_)), &instanceStaging_);
}

void SceneGpu::bindGeometry(VkCommandBuffer cmd) const
{
    const VkDeviceSize offset = 0;
    const VkBuffer vb = vertices_.handle();
    vkCmdBindVertexBuffers(cmd, 0, 1, &vb, &offset);
    vkCmdBindIndexBuffer(cmd, indices_.handle(), 0, VK_INDEX_TYPE_UINT32);
}

DrawCounts SceneGpu::record(VkCommandBuffer cmd, const std::function<void(const gpu::Image& texture)>& bindTexture) const
{
    const DrawBatch& batch = *scratch_;
    DrawCounts counts = batch.counts;
    if (batch.commands.empty()) return counts;
    bindGeometry(cmd);
    const bool indirect = multiDrawIndirect_ && batching_ == DrawBatching::Batched;
    const IndirectCommandArena::Region region = indirect ? arena_->store(batch.commands) : IndirectCommandArena::Region{};
    constexpr uint32_t stride = sizeof(VkDrawIndexedIndirectCommand);
    for (const DrawBatch::Group& group : batch.groups) {
        if (bindTexture) bindTexture(textures_[group.texture]);
        if (indirect) {
            for (uint32_t first = 0; first < group.commandCount; first += maxDrawIndirectCount_) {
                const uint32_t count = std::min(group.commandCount - first, maxDrawIndirectCount_);
                vkCmdDrawIndexedIndirect(cmd, region.buffer, region.offset + VkDeviceSize(group.firstCommand + first) * stride,
                                         count, stride);
                ++counts.drawCalls;
            }
            continue;
        }
        for (uint32_t c = group.firstCommand; c < group.firstCommand + group.commandCount; ++c) {
            const VkDrawIndexedIndirectCommand& d = batch.commands[c];
            vkCmdDrawIndexed(cmd, d.indexCount, d.instanceCount, d.firstIndex, d.vertexOffset, d.firstInstance);
            ++counts.drawCalls;
        }
    }
    return counts;
}

DrawCounts SceneGpu::draw(VkCommandBuffer cmd, DrawFilter filter,
                          const std::function<void(const gpu::Image& texture)>& bindTexture,
                          const std::vector<uint8_t>* instanceMask) const
{
    batches_->build(filter, instanceMask, bool(bindTexture), *scratch_);
    return record(cmd, bindTexture);
}

DrawCounts SceneGpu::drawInstances(VkCommandBuffer cmd, std::span<const uint32_t> instances, bool seeThrough) const
{
    batches_->buildInstances(instances, seeThrough, *scratch_);
    return record(cmd, {});
}

} // namespace penumbra::render
