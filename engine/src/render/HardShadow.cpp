#include "HardShadow.h"

#include "penumbra/gpu/Barrier.h"
#include "penumbra/gpu/Context.h"

#include <fmt/format.h>

namespace penumbra::render {

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

    gpu::ComputePipelineDesc c;
    c.name = "hard.visibility";
    c.shader = "hard/visibility.comp";
    c.bindings = {{0, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE},
                  {1, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER},
                  {2, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE}};
    c.pushConstantBytes = sizeof(glm::mat4);
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
      settings_(light.shadow),
      frustum_(spotLightFrustum(light.light, sceneBounds)),
      shadowMap_(context, {settings_.resolution, settings_.resolution, VK_FORMAT_D32_SFLOAT,
                           VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT,
                           fmt::format("light{}.shadow_map", lightIndex)}),
      visibility_(context, {width, height, VK_FORMAT_R32_SFLOAT,
                            VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                            fmt::format("light{}.visibility", lightIndex)})
{
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
    const uint32_t size = settings_.resolution;
    VkRenderingInfo info{VK_STRUCTURE_TYPE_RENDERING_INFO};
    info.renderArea = {{0, 0}, {size, size}};
    info.layerCount = 1;
    info.pDepthAttachment = &depth;
    vkCmdBeginRendering(cmd, &info);
    VkViewport viewport{0.0f, 0.0f, float(size), float(size), 0.0f, 1.0f};
    VkRect2D scissor{{0, 0}, {size, size}};
    vkCmdSetViewport(cmd, 0, 1, &viewport);
    vkCmdSetScissor(cmd, 0, 1, &scissor);
    // Reversed-Z: "away from the light" is towards smaller depth, so every bias term is
    // negated. A negative clamp bounds the bias from below (Vulkan: max(bias, clamp)).
    vkCmdSetDepthBias(cmd, -settings_.depthBiasConstant, -settings_.depthBiasClamp, -settings_.depthBiasSlope);
    pipelines_->depth.bind(cmd);
    gpu::DescriptorPush().storageBuffer(0, scene.instanceBuffer()).push(context_, cmd, pipelines_->depth);
    pipelines_->depth.pushConstants(cmd, &frustum_.viewProj, sizeof(glm::mat4));
    scene.drawAll(cmd);
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
        .push(context_, cmd, pipelines_->visibility);
    pipelines_->visibility.pushConstants(cmd, &frustum_.viewProj, sizeof(glm::mat4));
    const gpu::ImageDesc& d = visibility_.desc();
    vkCmdDispatch(cmd, (d.width + 7) / 8, (d.height + 7) / 8, 1);
    gpu::transition(cmd, visibility_, gpu::access::kComputeWrite, gpu::access::kComputeSampled);
}

} // namespace penumbra::render
