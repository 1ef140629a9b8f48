#pragma once
// Debug images that a technique computes only to show them (kernel sizes, a
// classification, list lengths): images of the render graph that no pass reads, written
// by a compute pass of their own. The graph culls that pass until one of its images is
// requested (FrameRenderer::requestImage, render --debug-image), and its pipeline is
// compiled on its first run: a debug view nobody looks at costs nothing.
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/graph/PassContext.h"
#include "penumbra/graph/RenderGraph.h"
#include "penumbra/plugin/Technique.h"

#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <string_view>

namespace penumbra::plugin {

// One debug image: the graph image io.local(name), R32_SFLOAT, which the shader writes as
// the storage image `binding`.
struct DebugImage {
    std::string_view name;     // "kernel"
    std::string_view binding;  // "kernelOut"
};

// Called as the pass records, with `pipeline` bound and the debug images (and, over the
// G-buffer, its bindings) in `descriptors`: add the technique's own inputs and push its
// constants into `pipeline` (pushed after it returns).
using BindDebugViewsFn =
    std::function<void(const graph::PassContext& pass, gpu::DescriptorPush& descriptors, const gpu::Pipeline& pipeline)>;

class DebugViewPass {
public:
    // `pipeline`: the shader that writes the images, compiled on the pass's first run.
    DebugViewPass(const TechniqueSetup& setup, gpu::ComputePipelineDesc pipeline);
    DebugViewPass(const DebugViewPass&) = delete;
    DebugViewPass& operator=(const DebugViewPass&) = delete;

    // Declares `images` at the screen's size (V_l's) and the compute pass `name`, which
    // reads the G-buffer (readGBuffer, bindGBuffer), binds `images` and what `bind` adds,
    // and dispatches one invocation per pixel. Returns the pass, for the technique's reads.
    graph::PassBuilder addOverGBuffer(graph::RenderGraph& graph, const LightPassIo& io, std::string name,
                                      std::span<const DebugImage> images, BindDebugViewsFn bind);

    // The same over an image of the technique's own (a light-space view, its atlas):
    // `images` of width x height, one invocation per texel, no G-buffer.
    graph::PassBuilder addOverTexels(graph::RenderGraph& graph, const LightPassIo& io, std::string name,
                                     std::span<const DebugImage> images, uint32_t width, uint32_t height,
                                     BindDebugViewsFn bind);

private:
    graph::PassBuilder add(graph::RenderGraph& graph, const LightPassIo& io, std::string name,
                           std::span<const DebugImage> images, uint32_t width, uint32_t height, bool overGBuffer,
                           BindDebugViewsFn bind);
    const gpu::Pipeline& pipeline();

    gpu::Context& context_;
    const gpu::ShaderCompiler& shaders_;
    const uint32_t screenWidth_, screenHeight_;
    const gpu::ComputePipelineDesc desc_;
    std::optional<gpu::Pipeline> pipeline_;
};

} // namespace penumbra::plugin
