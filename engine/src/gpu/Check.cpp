#include "penumbra/gpu/Check.h"

#include "penumbra/core/Error.h"

#include <fmt/format.h>

namespace penumbra::gpu {

const char* resultName(VkResult result)
{
    switch (result) {
    case VK_SUCCESS: return "VK_SUCCESS";
    case VK_NOT_READY: return "VK_NOT_READY";
    case VK_TIMEOUT: return "VK_TIMEOUT";
    case VK_INCOMPLETE: return "VK_INCOMPLETE";
    case VK_ERROR_OUT_OF_HOST_MEMORY: return "VK_ERROR_OUT_OF_HOST_MEMORY";
    case VK_ERROR_OUT_OF_DEVICE_MEMORY: return "VK_ERROR_OUT_OF_DEVICE_MEMORY";
    case VK_ERROR_INITIALIZATION_FAILED: return "VK_ERROR_INITIALIZATION_FAILED";
    case VK_ERROR_DEVICE_LOST: return "VK_ERROR_DEVICE_LOST";
    case VK_ERROR_MEMORY_MAP_FAILED: return "VK_ERROR_MEMORY_MAP_FAILED";
    case VK_ERROR_LAYER_NOT_PRESENT: return "VK_ERROR_LAYER_NOT_PRESENT";
    case VK_ERROR_EXTENSION_NOT_PRESENT: return "VK_ERROR_EXTENSION_NOT_PRESENT";
    case VK_ERROR_FEATURE_NOT_PRESENT: return "VK_ERROR_FEATURE_NOT_PRESENT";
    case VK_ERROR_INCOMPATIBLE_DRIVER: return "VK_ERROR_INCOMPATIBLE_DRIVER";
    case VK_ERROR_TOO_MANY_OBJECTS: return "VK_ERROR_TOO_MANY_OBJECTS";
    case VK_ERROR_FORMAT_NOT_SUPPORTED: return "VK_ERROR_FORMAT_NOT_SUPPORTED";
    case VK_ERROR_FRAGMENTED_POOL: return "VK_ERROR_FRAGMENTED_POOL";
    case VK_ERROR_OUT_OF_POOL_MEMORY: return "VK_ERROR_OUT_OF_POOL_MEMORY";
    default: return "VkResult(unknown)";
    }
}

void check(VkResult result, std::string_view what)
{
    if (result >= 0) {
        return;
    }
    std::string hint;
    if (result == VK_ERROR_INCOMPATIBLE_DRIVER) {
        hint = " (no Vulkan 1.3 driver found: install mesa-vulkan-drivers for lavapipe, "
               "or check VK_DRIVER_FILES / VK_ICD_FILENAMES)";
    } else if (result == VK_ERROR_DEVICE_LOST) {
        hint = " (the device was lost: the driver crashed or a submission hung)";
    }
    throw GpuError(fmt::format("Vulkan call failed: {}: {} ({}){}", what, resultName(result),
                               static_cast<int>(result), hint));
}

} // namespace penumbra::gpu
