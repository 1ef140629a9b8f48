#pragma once
// Memory offsets and sizes of the render graph's resources (RenderGraph.cpp's aliasing
// plan, GraphExecutor.cpp's allocations).
#include <vulkan/vulkan.h>

namespace penumbra::graph {

// `value` rounded up to the next multiple of `alignment` (> 0).
inline VkDeviceSize alignUp(VkDeviceSize value, VkDeviceSize alignment)
{
    return (value + alignment - 1) / alignment * alignment;
}

} // namespace penumbra::graph
