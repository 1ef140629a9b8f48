#pragma once
// The formats of the frame's output and camera depth, which the floor (FloorRenderer.cpp)
// draws into too, so that both are measured writing the same bytes.
#include <vulkan/vulkan.h>

namespace penumbra::frame {

inline constexpr VkFormat kFrameColorFormat = VK_FORMAT_R8G8B8A8_UNORM;
inline constexpr VkFormat kFrameDepthFormat = VK_FORMAT_D32_SFLOAT;
// The G-buffer's colour targets: shaders/common/gbuffer.glsl.
inline constexpr VkFormat kGBufferNormalFormat = VK_FORMAT_R16G16_SNORM;
inline constexpr VkFormat kGBufferAlbedoFormat = VK_FORMAT_R8G8B8A8_UNORM;

} // namespace penumbra::frame
