#pragma once
// The formats of the frame's output and camera depth, which the floor (FloorRenderer.cpp)
// draws into too, so that both are measured writing the same bytes.
#include <vulkan/vulkan.h>

namespace penumbra::frame {

inline constexpr VkFormat kFrameColorFormat = VK_FORMAT_R8G8B8A8_UNORM;
inline constexpr VkFormat kFrameDepthFormat = VK_FORMAT_D32_SFLOAT;

} // namespace penumbra::frame
