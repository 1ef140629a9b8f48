#include "penumbra/frame/BaseColorPipelines.h"

#include <fmt/format.h>

namespace penumbra::frame {

BaseColorPipelines::BaseColorPipelines(gpu::Context& context, const gpu::ShaderCompiler& shaders,
                                       gpu::GraphicsPipelineDesc desc)
{
    gpu::GraphicsPipelineDesc untextured = desc;
    untextured.name = fmt::format("{}.untextured", desc.name);
    untextured.defines.push_back({"BASE_COLOR_TEXTURE", "0"});
    untextured_ = gpu::Pipeline(context, shaders, untextured);
    desc.defines.push_back({"BASE_COLOR_TEXTURE", "1"});
    textured_ = gpu::Pipeline(context, shaders, desc);
}

const gpu::Pipeline& BaseColorPipelines::bindFor(VkCommandBuffer cmd, const render::SceneGpu& scene,
                                                 const gpu::Image& texture, const void* push, uint32_t pushBytes)
{
    const gpu::Pipeline& variant = scene.isUntextured(texture) ? untextured_ : textured_;
    if (bound_ != &variant) {
        variant.bind(cmd);
        // The two variants' descriptor layouts differ, so push constants do not carry over.
        variant.pushConstants(cmd, push, pushBytes);
        bound_ = &variant;
    }
    return variant;
}

} // namespace penumbra::frame
