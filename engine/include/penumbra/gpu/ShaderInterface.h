#pragma once
// What a compiled shader declares to the C++ that runs it, read from its SPIR-V: its
// descriptor bindings with their names, and a compute shader's workgroup size. A
// gpu::Pipeline builds its descriptor set layout from it, looks bindings up by name
// (gpu::DescriptorPush) and sizes dispatches with it (Pipeline::dispatchOver), so that
// binding numbers and local sizes are written once, in the GLSL.
#include <vulkan/vulkan.h>

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra::gpu {

struct ShaderBinding {
    // The variable's name (`gPosition`, the instance name of `buffer B {...} b;`); for a
    // block without an instance name, the block's name.
    std::string name;
    std::string blockName;  // uniform and storage buffers: the block's name (`B`); else empty
    uint32_t binding = 0;
    VkDescriptorType type = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;
    uint32_t count = 1;  // the array's length for an array of descriptors
    VkShaderStageFlags stages = 0;

    // A binding answers to its name and, for a buffer, to its block's name.
    bool isNamed(std::string_view n) const { return n == name || (!blockName.empty() && n == blockName); }
};

struct ShaderInterface {
    std::vector<ShaderBinding> bindings;  // ascending binding numbers, each once
    // local_size_x, _y, _z of a compute shader; zero for other stages.
    std::array<uint32_t, 3> localSize{0, 0, 0};

    // The binding that `name` names (isNamed), or null.
    const ShaderBinding* find(std::string_view name) const;
    // Adds another stage's bindings (a graphics pipeline's fragment shader to its vertex
    // shader's): a binding both declare must have one type and count there. Throws
    // ShaderCompileError naming `pipeline` otherwise.
    void merge(const ShaderInterface& other, std::string_view pipeline);
};

// Reads the interface of `spirv`, a module of one entry point for `stage`. Throws
// ShaderCompileError naming `shader` for what a pipeline with one push-descriptor set
// cannot bind: a resource outside descriptor set 0, an array of descriptors without a
// length, two declarations of one binding with different types.
ShaderInterface reflectShaderInterface(std::span<const uint32_t> spirv, VkShaderStageFlagBits stage,
                                       std::string_view shader);

// "storage image", "combined image sampler", ...: for messages.
const char* descriptorTypeName(VkDescriptorType type);

} // namespace penumbra::gpu
