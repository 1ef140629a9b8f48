#include "penumbra/plugin/VisibilityPass.h"

#include "penumbra/gpu/Barrier.h"
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/gpu/Resources.h"

#include <algorithm>
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
            // Only the pixels the light can light: shading reads V nowhere else, and V_l's
            // other pixels are filled with 1 for whoever reads the image.
            const uint32_t width = image.desc().width, height = image.desc().height;
            VkRect2D region{{0, 0}, {width, height}};
            if (io.screenRegion) {
                const VkRect2D asked = io.screenRegion();
                const int32_t x0 = std::clamp(asked.offset.x, 0, int32_t(width));
                const int32_t y0 = std::clamp(asked.offset.y, 0, int32_t(height));
                const int32_t x1 = std::clamp(int32_t(int64_t(asked.offset.x) + asked.extent.width), x0, int32_t(width));
                const int32_t y1 = std::clamp(int32_t(int64_t(asked.offset.y) + asked.extent.height), y0, int32_t(height));
                region = {{x0, y0}, {uint32_t(x1 - x0), uint32_t(y1 - y0)}};
            }
            if (region.extent.width == width && region.extent.height == height) {
                pipeline.dispatchOver(cmd, image);
                return;
            }
            const VkRect2D ran = pipeline.dispatchOverRegion(cmd, region);
            if (out != io.visibility || !io.fillOutside) return;  // a step's partial sum: read only inside
            gpu::memoryBarrier(cmd, gpu::access::kComputeStorageWrite, gpu::access::kComputeStorageWrite);
            io.fillOutside(cmd, image, ran);
        });
    return builder;
}

graph::PassBuilder addVisibilityPass(graph::RenderGraph& graph, const LightPassIo& io, const gpu::Pipeline& pipeline,
                                     BindVisibilityFn bind)
{
    return addVisibilityStepPass(graph, io, io.local("visibility"), io.visibility, pipeline, std::move(bind));
}

} // namespace penumbra::plugin
