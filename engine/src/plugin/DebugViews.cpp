#include "penumbra/plugin/DebugViews.h"

#include "penumbra/core/Error.h"
#include "penumbra/plugin/GBuffer.h"

#include <fmt/format.h>

#include <utility>
#include <vector>

namespace penumbra::plugin {

DebugViewPass::DebugViewPass(const TechniqueSetup& setup, gpu::ComputePipelineDesc pipeline)
    : context_(setup.context),
      shaders_(setup.shaders),
      screenWidth_(setup.width),
      screenHeight_(setup.height),
      desc_(std::move(pipeline))
{
}

const gpu::Pipeline& DebugViewPass::pipeline()
{
    if (!pipeline_) pipeline_.emplace(context_, shaders_, desc_);
    return *pipeline_;
}

graph::PassBuilder DebugViewPass::addOverGBuffer(graph::RenderGraph& graph, const LightPassIo& io, std::string name,
                                                 std::span<const DebugImage> images, BindDebugViewsFn bind)
{
    return add(graph, io, std::move(name), images, screenWidth_, screenHeight_, true, std::move(bind));
}

graph::PassBuilder DebugViewPass::addOverTexels(graph::RenderGraph& graph, const LightPassIo& io, std::string name,
                                                std::span<const DebugImage> images, uint32_t width, uint32_t height,
                                                BindDebugViewsFn bind)
{
    return add(graph, io, std::move(name), images, width, height, false, std::move(bind));
}

graph::PassBuilder DebugViewPass::add(graph::RenderGraph& graph, const LightPassIo& io, std::string name,
                                      std::span<const DebugImage> images, uint32_t width, uint32_t height,
                                      bool overGBuffer, BindDebugViewsFn bind)
{
    if (images.empty()) throw Error(fmt::format("debug-view pass '{}' declares no debug image", name));
    graph::PassBuilder pass = graph.addPass(std::move(name), graph::QueueKind::Compute);
    if (overGBuffer) readGBuffer(pass, io.gbuffer);
    std::vector<std::pair<std::string, std::string>> outputs;  // graph name, binding
    for (const DebugImage& image : images) {
        const std::string& graphName = outputs.emplace_back(io.local(image.name), std::string(image.binding)).first;
        graph.declareImage({graphName, width, height, VK_FORMAT_R32_SFLOAT});
        pass.write(graphName, graph::Usage::Storage);
    }
    pass.execute([this, gbuffer = overGBuffer ? std::optional<GBufferIo>(io.gbuffer) : std::nullopt,
                  outputs = std::move(outputs), bind = std::move(bind)](graph::PassContext& context) {
        const gpu::Pipeline& shader = pipeline();
        const VkCommandBuffer cmd = context.cmd();
        shader.bind(cmd);
        gpu::DescriptorPush descriptors;
        if (gbuffer) bindGBuffer(context, *gbuffer, descriptors);
        for (const auto& [graphName, binding] : outputs) descriptors.storageImage(binding, context.image(graphName));
        bind(context, descriptors, shader);
        descriptors.push(context_, cmd, shader);
        shader.dispatchOver(cmd, context.image(outputs.front().first));
    });
    return pass;
}

} // namespace penumbra::plugin
