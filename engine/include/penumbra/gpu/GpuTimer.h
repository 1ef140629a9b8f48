#pragma once
// GPU timestamps around named scopes (one per pass), read back after the frame.
#include <vulkan/vulkan.h>

#include <string>
#include <vector>

namespace penumbra::gpu {

class Context;

struct ScopeTime {
    std::string name;
    double gpuMs = 0.0;
};

class GpuTimer {
public:
    GpuTimer(Context& context, uint32_t maxScopes);
    ~GpuTimer();
    GpuTimer(const GpuTimer&) = delete;
    GpuTimer& operator=(const GpuTimer&) = delete;

    // Resets the query pool; call at the start of a command buffer, outside rendering.
    void beginFrame(VkCommandBuffer cmd);
    uint32_t beginScope(VkCommandBuffer cmd, const std::string& name);
    void endScope(VkCommandBuffer cmd, uint32_t scope);
    // After the frame's submission finished: the time of every scope, in record order.
    std::vector<ScopeTime> collect() const;

private:
    Context& context_;
    VkQueryPool pool_ = VK_NULL_HANDLE;
    uint32_t maxScopes_ = 0;
    std::vector<std::string> names_;
    double nsPerTick_ = 1.0;
    uint64_t validMask_ = ~0ull;
};

} // namespace penumbra::gpu
