#pragma once
// A technique's compute pipelines, named in its own namespace ("light0.deep.sort") so
// that an error or a GPU debugger says which light's technique it is.
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/plugin/Technique.h"

#include <cstdint>
#include <filesystem>
#include <string_view>
#include <vector>

namespace penumbra::plugin {

// The description of the compute pipeline setup.local(name): `shader` (relative to the
// plugin's shader folder), its defines and the bytes of its push constants.
gpu::ComputePipelineDesc computePipelineDesc(const TechniqueSetup& setup, std::string_view name,
                                             std::filesystem::path shader, std::vector<gpu::ShaderDefine> defines = {},
                                             uint32_t pushConstantBytes = 0);

// That pipeline, compiled (throws gpu::ShaderCompileError or penumbra::Error naming it).
gpu::Pipeline createComputePipeline(const TechniqueSetup& setup, std::string_view name, std::filesystem::path shader,
                                    std::vector<gpu::ShaderDefine> defines = {}, uint32_t pushConstantBytes = 0);

} // namespace penumbra::plugin
