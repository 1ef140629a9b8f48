#pragma once
// Where render::SceneGpu puts the indirect commands of a frame's draws: host-visible
// buffers that the device reads when it executes the commands recorded with them, so a
// region stays untouched until the device has finished that frame. The regions are
// handed out one after the other; beginFrame() starts again from the first buffer. A new
// buffer is added only when a frame needs more than every earlier one did, and kept: after
// the first frames nothing is allocated per frame.
#include "penumbra/gpu/Resources.h"

#include <vulkan/vulkan.h>

#include <cstdint>
#include <span>
#include <vector>

namespace penumbra::gpu {
class Context;
}

namespace penumbra::render {

class IndirectCommandArena {
public:
    // `commandsPerBuffer`: the size of each buffer (a larger request gets a buffer of its
    // own size).
    IndirectCommandArena(gpu::Context& context, uint32_t commandsPerBuffer);

    struct Region {
        VkBuffer buffer = VK_NULL_HANDLE;
        VkDeviceSize offset = 0;  // bytes
    };
    // Copies `commands` into the next free region (contiguous, in one buffer).
    Region store(std::span<const VkDrawIndexedIndirectCommand> commands);

    // Every region handed out since the last call may be reused: call it once the device
    // has finished every command buffer recorded with them.
    void beginFrame();

private:
    gpu::Context& context_;
    uint32_t commandsPerBuffer_;
    std::vector<gpu::Buffer> buffers_;
    size_t current_ = 0;    // the buffer being filled
    uint64_t used_ = 0;     // commands in it
};

} // namespace penumbra::render
