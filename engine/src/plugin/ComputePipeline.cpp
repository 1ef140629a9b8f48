#include "penumbra/plugin/ComputePipeline.h"

#include <utility>

namespace penumbra::plugin {

gpu::ComputePipelineDesc computePipelineDesc(const TechniqueSetup& setup, std::string_view name,
                                             std::filesystem::path shader, std::vector<gpu::ShaderDefine> defines,
                                             uint32_t pushConstantBytes)
{
    return {setup.local(name), std::move(shader), std::move(defines), pushConstantBytes};
}

gpu::Pipeline createComputePipeline(const TechniqueSetup& setup, std::string_view name, std::filesystem::path shader,
                                    std::vector<gpu::ShaderDefine> defines, uint32_t pushConstantBytes)
{
    return gpu::Pipeline(setup.context, setup.shaders,
                         computePipelineDesc(setup, name, std::move(shader), std::move(defines), pushConstantBytes));
}

} // namespace penumbra::plugin
