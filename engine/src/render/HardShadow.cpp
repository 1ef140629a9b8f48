#include "HardShadow.h"

#include "penumbra/gpu/Barrier.h"
#include "penumbra/gpu/Context.h"

#include <fmt/format.h>

namespace penumbra::render {
namespace {

struct VisibilityPush {  // matches shaders/hard/visibility.comp
    glm::vec4 lightPosition;
    uint32_t faceCount;
    float faceTexels;
};

template <class T>
T paramOr(const config::ShadowSettings& s, const char* name, T fallback)
{
    const nlohmann::json* v = s.param(name);
    return v ? v->get<T>() : fallback;
}

uint32_t faceCount(const scene::Light& light)
{
    return light.type == scene::LightType::Spot || light.type == scene::LightType::Directional ? 1u : 6u;
}

} // namespace

HardShadowPipelines::HardShadowPipelines(gpu::Context& ctx, const gpu::ShaderCompiler& compiler, uint32_t vertexStride)
    : context(ctx)
{
    gpu::GraphicsPipelineDesc d;
    d.name = "hard.shadow_map";
    d.vertexShader = "hard/shadow_depth.vert";
    d.bindings = {{0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER}};
    d.pushConstantBytes = sizeof(glm::mat4);
    d.vertexLayout = {vertexStride, {{0, 0, VK_FORMAT_R32G32B32_SFLOAT, 0}}};
    d.depthFormat = VK_FORMAT_D32_SFLOAT;
    d.depthCompare = VK_COMPARE_OP_GREATER_OR_EQUAL;  // reversed-Z: nearer is larger
    d.depthBias = true;
    // Both faces cast: a receiver's own back faces would otherwise let light leak
    // through single-sided or open geometry.
    d.cullMode = VK_CULL_MODE_NONE;
    depth = gpu::Pipeline(ctx, compiler, d);

    d.name = "hard.shadow_map.masked";
    d.fragmentShader = "hard/shadow_masked.frag";
    d.defines = {{"ALPHA_MASK", "1"}};
    d.bindings = {{0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},
                  {1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},
                  {2, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER}};
    d.vertexLayout.attributes.push_back({2, 0, VK_FORMAT_R32G32_SFLOAT, offsetof(scene::Vertex, uv)});
    depthMasked = gpu::Pipeline(ctx, compiler, d);

    gpu::ComputePipelineDesc c;
    c.name = "hard.visibility";
    c.shader = "hard/visibility.comp";
    c.bindings = {{0, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE},
                  {1, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER},
                  {2, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE},
                  {3, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER}};
    c.pushConstantBytes = sizeof(VisibilityPush);
    visibility = gpu::Pipeline(ctx, compiler, c);
    // Nearest filtering: one comparison, a hard 0/1 result. Points outside the map never
    // reach the sampler: the shader treats them as lit.
    compareSampler = gpu::createSampler(ctx, VK_FILTER_NEAREST, VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE,
                                        VK_COMPARE_OP_GREATER_OR_EQUAL);
}

HardShadowPipelines::~HardShadowPipelines() { vkDestroySampler(context.device(), compareSampler, nullptr); }

HardShadow::HardShadow(gpu::Context& context, std::shared_ptr<HardShadowPipelines> pipelines,
                       const config::LightConfig& light, const scene::Aabb& sceneBounds, uint32_t width,
                       uint32_t height, size_t lightIndex)
    : context_(context),
      pipelines_(std::move(pipelines)),
      settings_{paramOr<uint32_t>(light.shadow, "resolution", 2048u), paramOr<float>(light.shadow, "depth_bias", 4.0f),
                paramOr<float>(light.shadow, "slope_bias", 2.0f), paramOr<float>(light.shadow, "bias_clamp", 0.0f)},
      faceCount_(faceCount(light.light)),
      // Six faces share one atlas, 3 x 2 faces of resolution² each.
      shadowMap_(context, {settings_.resolution * (faceCount_ == 6 ? 3u : 1u),
                           settings_.resolution * (faceCount_ == 6 ? 2u : 1u), VK_FORMAT_D32_SFLOAT,
                           VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT,
                           fmt::format("light{}.shadow_map", lightIndex)}),
      visibility_(context, {width, height, VK_FORMAT_R32_SFLOAT,
                            VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                            fmt::format("light{}.visibility", lightIndex)}),
      frustumBuffer_(context, sizeof(glm::mat4) * kMaxFaces, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true,
                     fmt::format("light{}.frusta", lightIndex))
{
    update(light.light, sceneBounds);
}

void HardShadow::update(const scene::Light& light, const scene::Aabb& sceneBounds)
{
    frusta_ = shadowFrusta(light, sceneBounds);
    lightPosition_ = light.position;
    auto* matrices = static_cast<glm::mat4*>(frustumBuffer_.mapped());
    for (size_t i = 0; i < frusta_.size(); ++i) matrices[i] = frusta_[i].viewProj;
}

void HardShadow::recordShadowMap(VkCommandBuffer cmd, const SceneGpu& scene) const
{
    gpu::transition(cmd, shadowMap_, gpu::access::kUndefined, gpu::access::kDepthAttachment);
    VkRenderingAttachmentInfo depth{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
    depth.imageView = shadowMap_.view();
    depth.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
    depth.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
    depth.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    depth.clearValue.depthStencil = {0.0f, 0};  // reversed-Z: far is 0
    const gpu::ImageDesc& map = shadowMap_.desc();
    VkRenderingInfo info{VK_STRUCTURE_TYPE_RENDERING_INFO};
    info.renderArea = {{0, 0}, {map.width, map.height}};
    info.layerCount = 1;
    info.pDepthAttachment = &depth;
    vkCmdBeginRendering(cmd, &info);
    // Reversed-Z: "away from the light" is towards smaller depth, so every bias term is
    // negated. A negative clamp bounds the bias from below (Vulkan: max(bias, clamp)).
    vkCmdSetDepthBias(cmd, -settings_.depthBiasConstant, -settings_.depthBiasClamp, -settings_.depthBiasSlope);
    const uint32_t size = settings_.resolution;
    const bool masked = scene.hasAlphaMasked();
    for (uint32_t face = 0; face < frusta_.size(); ++face) {
        // Each face draws into its own cell of the atlas (the scissor keeps it there).
        const int32_t x = int32_t((face % 3) * size), y = int32_t((face / 3) * size);
        VkViewport viewport{float(x), float(y), float(size), float(size), 0.0f, 1.0f};
        VkRect2D scissor{{x, y}, {size, size}};
        vkCmdSetViewport(cmd, 0, 1, &viewport);
        vkCmdSetScissor(cmd, 0, 1, &scissor);
        // The solid pipeline stays bound across faces unless the masked one replaced it.
        if (face == 0 || masked) {
            pipelines_->depth.bind(cmd);
            gpu::DescriptorPush().storageBuffer(0, scene.instanceBuffer()).push(context_, cmd, pipelines_->depth);
        }
        pipelines_->depth.pushConstants(cmd, &frusta_[face].viewProj, sizeof(glm::mat4));
        scene.draw(cmd, DrawFilter::Solid);
        if (!masked) continue;
        const gpu::Pipeline& m = pipelines_->depthMasked;
        m.bind(cmd);
        m.pushConstants(cmd, &frusta_[face].viewProj, sizeof(glm::mat4));
        scene.draw(cmd, DrawFilter::AlphaMasked, [&](const gpu::Image& texture) {
            gpu::DescriptorPush()
                .storageBuffer(0, scene.instanceBuffer())
                .storageBuffer(1, scene.materialBuffer())
                .sampledImage(2, texture, scene.textureSampler())
                .push(context_, cmd, m);
        });
    }
    vkCmdEndRendering(cmd);
    gpu::transition(cmd, shadowMap_, gpu::access::kDepthAttachment, gpu::access::kComputeSampledDepth);
}

void HardShadow::recordVisibility(VkCommandBuffer cmd, const gpu::Image& gPosition) const
{
    gpu::transition(cmd, visibility_, gpu::access::kUndefined, gpu::access::kComputeWrite);
    pipelines_->visibility.bind(cmd);
    gpu::DescriptorPush()
        .storageImage(0, gPosition)
        .sampledImage(1, shadowMap_, pipelines_->compareSampler, VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL)
        .storageImage(2, visibility_)
        .storageBuffer(3, frustumBuffer_)
        .push(context_, cmd, pipelines_->visibility);
    const VisibilityPush push{glm::vec4(lightPosition_, 1.0f), faceCount_, float(settings_.resolution)};
    pipelines_->visibility.pushConstants(cmd, &push, sizeof(push));
    const gpu::ImageDesc& d = visibility_.desc();
    vkCmdDispatch(cmd, (d.width + 7) / 8, (d.height + 7) / 8, 1);
    gpu::transition(cmd, visibility_, gpu::access::kComputeWrite, gpu::access::kComputeSampled);
}

} // namespace penumbra::render
