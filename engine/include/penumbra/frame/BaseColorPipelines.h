#pragma once
// A scene-drawing graphics pipeline compiled twice: with BASE_COLOR_TEXTURE 1, which
// samples the material's base-colour texture, and 0, for the draws of untextured
// materials (render::SceneGpu's white 1x1 default, whose sample is exactly 1). On
// llvmpipe the bilinear sample is a third of the G-buffer pass (5 of 15 ms on
// config/default.json, docs/performance.md); a classic engine keeps the same two
// variants. Shared by the frame's G-buffer pass and the floor's forward draw.
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/render/SceneGpu.h"

#include <vulkan/vulkan.h>

#include <cstdint>

namespace penumbra::frame {

class BaseColorPipelines {
public:
    BaseColorPipelines() = default;
    // `desc` names the textured variant; the untextured one is named desc.name + ".untextured".
    BaseColorPipelines(gpu::Context& context, const gpu::ShaderCompiler& shaders, gpu::GraphicsPipelineDesc desc);

    // Call once per group of draws that share `texture` (SceneGpu::draw's bindTexture):
    // binds the variant for it when another (or none, after begin()) is bound, pushing
    // `push` with it. Returns the variant; textured(variant) says whether its
    // "baseColorTexture" must be bound.
    const gpu::Pipeline& bindFor(VkCommandBuffer cmd, const render::SceneGpu& scene, const gpu::Image& texture,
                                 const void* push, uint32_t pushBytes);
    bool textured(const gpu::Pipeline& variant) const { return &variant == &textured_; }
    // Before a pass's draws: nothing is bound yet.
    void begin() { bound_ = nullptr; }

private:
    gpu::Pipeline textured_;
    gpu::Pipeline untextured_;
    const gpu::Pipeline* bound_ = nullptr;
};

} // namespace penumbra::frame
