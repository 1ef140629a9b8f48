#pragma once
// Every Vulkan result is checked (STYLE.md): a failure becomes a GpuError that names the
// call and the result code, never a silent black image.
#include <vulkan/vulkan.h>

#include <string_view>

namespace penumbra::gpu {

const char* resultName(VkResult result);

// Throws GpuError("<what>: <VkResult name>") when result is an error code.
void check(VkResult result, std::string_view what);

} // namespace penumbra::gpu

#define PENUMBRA_VK(call) ::penumbra::gpu::check((call), #call)
