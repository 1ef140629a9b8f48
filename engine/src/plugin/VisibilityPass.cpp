#include "penumbra/plugin/VisibilityPass.h"

#include <utility>

namespace penumbra::plugin {

graph::PassBuilder addVisibilityPass(graph::RenderGraph& graph, const LightPassIo& io, const gpu::Pipeline& pipeline,
                                     BindVisibilityFn bind)
{
    // A compute pass: a full-screen fragment pass was measured no faster on llvmpipe for
    // the shading pass, whose per-pixel work is the lighter (docs/performance.md,
    // "Full-screen passes").
    graph::PassBuilder builder = graph.addPass(io.local("visibility"), graph::QueueKind::Compute);
    readGBuffer(builder, io.gbuffer);
    builder.write(io.visibility, graph::Usage::Storage)
        .execute([io, &pipeline, bind = std::move(bind)](graph::PassContext& pass) {
            const VkCommandBuffer cmd = pass.cmd();
            const gpu::Image& out = pass.image(io.visibility);
            pipeline.bind(cmd);
            gpu::DescriptorPush descriptors;
            bindGBuffer(pass, io.gbuffer, descriptors);
            descriptors.storageImage("visibilityOut", out);
            bind(pass, descriptors);
            descriptors.push(pass.context(), cmd, pipeline);
            pipeline.dispatchOver(cmd, out);
        });
    return builder;
}

} // namespace penumbra::plugin
