#include "penumbra/plugin/GBuffer.h"

#include "penumbra/core/Error.h"

#include <fmt/format.h>

namespace penumbra::plugin {
namespace {

// common/gbuffer.glsl's bindings.
void addBindings(gpu::DescriptorPush& descriptors, const gpu::Image& depth, VkImageLayout depthLayout,
                 const gpu::Image& normal, VkImageLayout normalLayout, const gpu::Buffer& camera, VkSampler sampler)
{
    descriptors.sampledImage("gDepth", depth, sampler, depthLayout)
        .sampledImage("gNormal", normal, sampler, normalLayout)
        .uniformBuffer("GBufferCamera", camera);
}

} // namespace

void readGBuffer(graph::PassBuilder& pass, const GBufferIo& gbuffer)
{
    pass.read(gbuffer.depth, graph::Usage::Sampled).read(gbuffer.normal, graph::Usage::Sampled);
}

void bindGBuffer(const graph::PassContext& pass, const GBufferIo& gbuffer, gpu::DescriptorPush& descriptors)
{
    if (gbuffer.camera == nullptr || gbuffer.sampler == VK_NULL_HANDLE) {
        throw Error("bindGBuffer: the LightPassIo's G-buffer has no camera buffer or sampler (the engine sets them)");
    }
    addBindings(descriptors, pass.image(gbuffer.depth), pass.layout(gbuffer.depth), pass.image(gbuffer.normal),
                pass.layout(gbuffer.normal), *gbuffer.camera, gbuffer.sampler);
}

GBufferExport::GBufferExport(gpu::Context& context, const gpu::ShaderCompiler& shaders) : context_(context)
{
    gpu::ComputePipelineDesc desc;
    desc.name = "gbuffer_export";
    desc.shader = "engine/gbuffer_export.comp";
    pipeline_ = gpu::Pipeline(context, shaders, desc);
}

graph::PassBuilder GBufferExport::addPass(graph::RenderGraph& graph, const std::string& name,
                                          const GBufferIo& gbuffer, const std::string& positions,
                                          const std::string& normals) const
{
    graph::PassBuilder pass = graph.addPass(name, graph::QueueKind::Compute);
    readGBuffer(pass, gbuffer);
    pass.write(positions, graph::Usage::Storage)
        .write(normals, graph::Usage::Storage)
        .execute([this, gbuffer, positions, normals](graph::PassContext& ctx) {
            record(ctx.cmd(), ctx.image(gbuffer.depth), ctx.layout(gbuffer.depth), ctx.image(gbuffer.normal),
                   ctx.layout(gbuffer.normal), *gbuffer.camera, gbuffer.sampler, ctx.buffer(positions),
                   ctx.buffer(normals));
        });
    return pass;
}

void GBufferExport::record(VkCommandBuffer cmd, const gpu::Image& depth, VkImageLayout depthLayout,
                           const gpu::Image& normal, VkImageLayout normalLayout, const gpu::Buffer& camera,
                           VkSampler sampler, const gpu::Buffer& positions, const gpu::Buffer& normals) const
{
    const VkDeviceSize bytes = VkDeviceSize(depth.desc().width) * depth.desc().height * kTexelBytes;
    if (positions.size() < bytes || normals.size() < bytes) {
        throw Error(fmt::format("gbuffer_export: buffers of {} and {} bytes, the G-buffer needs {}", positions.size(),
                                normals.size(), bytes));
    }
    pipeline_.bind(cmd);
    gpu::DescriptorPush descriptors;
    addBindings(descriptors, depth, depthLayout, normal, normalLayout, camera, sampler);
    descriptors.storageBuffer("Positions", positions).storageBuffer("Normals", normals).push(context_, cmd, pipeline_);
    pipeline_.dispatchOver(cmd, depth);
}

} // namespace penumbra::plugin
