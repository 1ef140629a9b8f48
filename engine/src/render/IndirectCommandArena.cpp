#include "render/IndirectCommandArena.h"

#include <fmt/format.h>

#include <algorithm>
#include <cstring>

namespace penumbra::render {

IndirectCommandArena::IndirectCommandArena(gpu::Context& context, uint32_t commandsPerBuffer)
    : context_(context), commandsPerBuffer_(std::max(commandsPerBuffer, 1u))
{
}

IndirectCommandArena::Region IndirectCommandArena::store(std::span<const VkDrawIndexedIndirectCommand> commands)
{
    constexpr VkDeviceSize stride = sizeof(VkDrawIndexedIndirectCommand);
    // The next buffer that holds the whole request; a new one when none does.
    while (current_ < buffers_.size() && buffers_[current_].size() / stride - used_ < commands.size()) {
        ++current_;
        used_ = 0;
    }
    if (current_ == buffers_.size()) {
        const uint64_t capacity = std::max<uint64_t>(commandsPerBuffer_, commands.size());
        buffers_.emplace_back(context_, capacity * stride, VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT, true,
                              fmt::format("scene indirect commands {}", buffers_.size()));
        used_ = 0;
    }
    const gpu::Buffer& buffer = buffers_[current_];
    const Region region{buffer.handle(), used_ * stride};
    std::memcpy(static_cast<std::byte*>(buffer.mapped()) + region.offset, commands.data(), commands.size_bytes());
    used_ += commands.size();
    return region;
}

void IndirectCommandArena::beginFrame()
{
    current_ = 0;
    used_ = 0;
}

} // namespace penumbra::render
