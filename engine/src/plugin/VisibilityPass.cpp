#include "penumbra/plugin/VisibilityPass.h"

#include <utility>

namespace penumbra::plugin {

graph::PassBuilder addVisibilityStepPass(graph::RenderGraph& graph, const LightPassIo& io, std::string name,
                                         std::string out, const gpu::Pipeline& pipeline, BindVisibilityFn bind)
{
    // A compute pass: a full-screen fragment pass was measured no faster on llvmpipe for
    // the shading pass, whose per-pixel work is the lighter (docs/performance.md,
    // "Full-screen passes").
    graph::PassBuilder builder = graph.addPass(std::move(name), graph::QueueKind::Compute);
    readGBuffer(builder, io.gbuffer);
    builder.write(out, graph::Usage::Storage)
        .execute([io, out, &pipeline, bind = std::move(bind)](graph::PassContext& pass) {
            const VkCommandBuffer cmd = pass.cmd();
            const gpu::Image& image = pass.image(out);
            pipeline.bind(cmd);
            gpu::DescriptorPush descriptors;
            bindGBuffer(pass, io.gbuffer, descriptors);
            descriptors.storageImage("visibilityOut", image);
            bind(pass, descriptors);
            descriptors.push(pass.context(), cmd, pipeline);
            pipeline.dispatchOver(cmd, image);
        });
    return builder;
}

graph::PassBuilder addVisibilityPass(graph::RenderGraph& graph, const LightPassIo& io, const gpu::Pipeline& pipeline,
                                     BindVisibilityFn bind)
{
    return addVisibilityStepPass(graph, io, io.local("visibility"), io.visibility, pipeline, std::move(bind));
}

} // namespace penumbra::plugin
