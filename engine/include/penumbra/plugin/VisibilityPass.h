#pragma once
// The pass a technique ends with: a compute shader run once per pixel of V_l that reads
// the G-buffer (common/gbuffer.glsl: gbufferPosition, gbufferNormal) and writes the
// light's visibility image
// (docs/plugins.md, "The contract"). Declared and recorded here once, so that a technique
// says only what it adds: its own inputs, descriptors and push constants.
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/graph/PassContext.h"
#include "penumbra/graph/RenderGraph.h"
#include "penumbra/plugin/Technique.h"

#include <functional>

namespace penumbra::plugin {

// V_l's format (shaders/common/visibility.glsl VISIBILITY_FORMAT, which says why): also
// that of the steps of addVisibilityStepPass that a shader writes as visibilityOut.
inline constexpr VkFormat kVisibilityFormat = VK_FORMAT_R16_UNORM;

// Called as the pass records, with the pipeline bound: add the technique's own
// descriptors to `descriptors` (pushed after it returns, with the G-buffer's and V_l's)
// and push its constants into pass.cmd().
using BindVisibilityFn = std::function<void(const graph::PassContext& pass, gpu::DescriptorPush& descriptors)>;

// Declares the compute pass io.local("visibility"), which reads the G-buffer (readGBuffer)
// and writes io.visibility as the storage image that `pipeline`'s shader names
// visibilityOut. Each frame it binds `pipeline`, pushes the G-buffer's bindings
// (bindGBuffer), visibilityOut and what `bind` adds, and dispatches one invocation per pixel of V_l
// (Pipeline::dispatchOver). Returns the pass, for the technique's own reads (its shadow
// map, ...). `pipeline` must live as long as the technique (a member of it).
graph::PassBuilder addVisibilityPass(graph::RenderGraph& graph, const LightPassIo& io, const gpu::Pipeline& pipeline,
                                     BindVisibilityFn bind);

// The same pass for a step towards V_l (one sub-light's share of a sum that the last step
// writes into V_l): named `name`, it writes the screen-size storage image `out`, which the
// technique declares, as visibilityOut instead of io.visibility.
graph::PassBuilder addVisibilityStepPass(graph::RenderGraph& graph, const LightPassIo& io, std::string name,
                                         std::string out, const gpu::Pipeline& pipeline, BindVisibilityFn bind);

} // namespace penumbra::plugin
