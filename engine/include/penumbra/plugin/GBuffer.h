#pragma once
// The G-buffer as a technique reads it. Shaders read world positions and normals with
// shaders/common/gbuffer.glsl's gbufferPosition / gbufferNormal, never an image or a
// format: the C++ side declares those reads with readGBuffer and binds them with
// bindGBuffer (plugin::addVisibilityPass does both). Work on the CPU gets the same
// positions and normals as plain floats from GBufferExport.
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/gpu/Resources.h"
#include "penumbra/gpu/ShaderCompiler.h"
#include "penumbra/graph/PassContext.h"
#include "penumbra/graph/RenderGraph.h"

#include <string>

namespace penumbra::plugin {

// What the engine hands a technique about its G-buffer (LightPassIo::gbuffer).
struct GBufferIo {
    std::string depth = "gbuffer.depth";    // graph images, read as Usage::Sampled
    std::string normal = "gbuffer.normal";
    const gpu::Buffer* camera = nullptr;    // the unprojection (engine-owned, rewritten before each frame)
    VkSampler sampler = VK_NULL_HANDLE;     // nearest, clamped (texelFetch ignores it)
};

// Declares that `pass` reads the G-buffer (its depth and normal images, sampled).
void readGBuffer(graph::PassBuilder& pass, const GBufferIo& gbuffer);

// Adds the bindings of common/gbuffer.glsl (gDepth, gNormal, GBufferCamera) to
// `descriptors`, for a pass that called readGBuffer.
void bindGBuffer(const graph::PassContext& pass, const GBufferIo& gbuffer, gpu::DescriptorPush& descriptors);

// The G-buffer for the CPU: per pixel (rows top first) a world position (xyz, w = 1
// where the pixel sees geometry, all 0 elsewhere) and a unit world normal (xyz; w: the
// position's error bound, gbufferPositionError, in world units; all 0 where no
// geometry), both as four floats, computed by gbufferPosition, gbufferNormal and
// gbufferPositionError on the GPU.
class GBufferExport {
public:
    static constexpr VkDeviceSize kTexelBytes = 4 * sizeof(float);  // per pixel, in each buffer

    // `shaders` finds the engine's shaders (a technique's TechniqueSetup::shaders does).
    GBufferExport(gpu::Context& context, const gpu::ShaderCompiler& shaders);

    // Declares the compute pass `name`, which reads the G-buffer and writes `positions`
    // and `normals`, graph buffers of kTexelBytes per pixel.
    graph::PassBuilder addPass(graph::RenderGraph& graph, const std::string& name, const GBufferIo& gbuffer,
                               const std::string& positions, const std::string& normals) const;

    // Records the same outside a graph: `depth` and `normal` in the layouts given (each
    // one a layout a shader may sample in), buffers of kTexelBytes per pixel of `depth`.
    void record(VkCommandBuffer cmd, const gpu::Image& depth, VkImageLayout depthLayout, const gpu::Image& normal,
                VkImageLayout normalLayout, const gpu::Buffer& camera, VkSampler sampler,
                const gpu::Buffer& positions, const gpu::Buffer& normals) const;

private:
    gpu::Context& context_;
    gpu::Pipeline pipeline_;
};

} // namespace penumbra::plugin
