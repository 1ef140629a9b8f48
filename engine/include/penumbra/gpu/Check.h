#pragma once
// Every Vulkan result is checked (STYLE.md): a failure becomes a GpuError that names the
// call and the result code, never a silent black image.
#include "penumbra/core/Error.h"

#include <vulkan/vulkan.h>

#include <string>
#include <string_view>

namespace penumbra::gpu {

const char* resultName(VkResult result);
// "D32_SFLOAT", "R32G32_SFLOAT": the formats the engine and its plugins use; others by number.
std::string formatName(VkFormat format);

// A failed Vulkan call: a GpuError that keeps its result, for callers that tell the
// causes apart (a lost device, memory).
class VulkanError : public GpuError {
public:
    VulkanError(const std::string& message, VkResult result) : GpuError(message), result_(result) {}
    VkResult result() const { return result_; }

private:
    VkResult result_;
};

// Throws VulkanError("<what>: <VkResult name>") when result is an error code.
void check(VkResult result, std::string_view what);

} // namespace penumbra::gpu

#define PENUMBRA_VK(call) ::penumbra::gpu::check((call), #call)
