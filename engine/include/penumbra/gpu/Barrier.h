#pragma once
// Image layout transitions with synchronization2. Written by hand in the foundation's
// fixed frame; the pass scheduler derives them from declared accesses.
#include <vulkan/vulkan.h>

namespace penumbra::gpu {

class Image;

struct ImageAccess {
    VkImageLayout layout;
    VkPipelineStageFlags2 stage;
    VkAccessFlags2 access;
};

struct MemoryAccess {
    VkPipelineStageFlags2 stage;
    VkAccessFlags2 access;
};

// A global memory dependency: `before`'s writes become visible to `after`.
void memoryBarrier(VkCommandBuffer cmd, const MemoryAccess& before, const MemoryAccess& after);

// Transitions `image` from `before` (what last touched it) to `after` (the next use).
void transition(VkCommandBuffer cmd, const Image& image, const ImageAccess& before, const ImageAccess& after);

namespace access {
inline constexpr ImageAccess kUndefined{VK_IMAGE_LAYOUT_UNDEFINED, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, 0};
inline constexpr ImageAccess kColorAttachment{VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
                                              VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                                              VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT};
inline constexpr ImageAccess kDepthAttachment{VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL,
                                              VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT |
                                                  VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
                                              VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT |
                                                  VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT};
inline constexpr ImageAccess kComputeRead{VK_IMAGE_LAYOUT_GENERAL, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                                          VK_ACCESS_2_SHADER_STORAGE_READ_BIT};
inline constexpr ImageAccess kComputeWrite{VK_IMAGE_LAYOUT_GENERAL, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                                           VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT};
inline constexpr ImageAccess kComputeSampled{VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL,
                                             VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                                             VK_ACCESS_2_SHADER_SAMPLED_READ_BIT};
inline constexpr ImageAccess kComputeSampledDepth{VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL,
                                                  VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                                                  VK_ACCESS_2_SHADER_SAMPLED_READ_BIT};

// Memory scopes (MemoryAccess, for memoryBarrier) of compute dispatches' storage
// accesses: the dependency between two steps of one pass (a summed-area table's row then
// column sweep, a pyramid's levels), which the render graph, ordering whole passes, does
// not see.
inline constexpr MemoryAccess kComputeStorageWrite{VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                                                   VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT};
inline constexpr MemoryAccess kComputeStorageReadWrite{
    VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT};
// The host reading mapped memory after the submission's wait (work outside a render
// graph; in one, RenderGraph::readBack).
inline constexpr MemoryAccess kHostRead{VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT};
} // namespace access

} // namespace penumbra::gpu
