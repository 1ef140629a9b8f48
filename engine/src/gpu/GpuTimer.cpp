#include "penumbra/gpu/GpuTimer.h"

#include "penumbra/core/Error.h"
#include "penumbra/gpu/Barrier.h"
#include "penumbra/gpu/Check.h"
#include "penumbra/gpu/Context.h"

#include <fmt/format.h>

namespace penumbra::gpu {

GpuTimer::GpuTimer(Context& context, uint32_t maxScopes) : context_(context), maxScopes_(maxScopes)
{
    VkQueryPoolCreateInfo info{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
    info.queryType = VK_QUERY_TYPE_TIMESTAMP;
    info.queryCount = 2 * maxScopes;
    check(vkCreateQueryPool(context.device(), &info, nullptr, &pool_), "vkCreateQueryPool (timestamps)");
    nsPerTick_ = context.properties().limits.timestampPeriod;
    uint32_t familyCount = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(context.physicalDevice(), &familyCount, nullptr);
    std::vector<VkQueueFamilyProperties> families(familyCount);
    vkGetPhysicalDeviceQueueFamilyProperties(context.physicalDevice(), &familyCount, families.data());
    const uint32_t bits = families[context.queueFamily()].timestampValidBits;
    validMask_ = bits >= 64 ? ~0ull : ((1ull << bits) - 1);
}

GpuTimer::~GpuTimer() { vkDestroyQueryPool(context_.device(), pool_, nullptr); }

void GpuTimer::beginFrame(VkCommandBuffer cmd)
{
    vkCmdResetQueryPool(cmd, pool_, 0, 2 * maxScopes_);
    names_.clear();
}

uint32_t GpuTimer::beginScope(VkCommandBuffer cmd, const std::string& name)
{
    if (names_.size() >= maxScopes_) {
        throw GpuError(fmt::format("GpuTimer: more than {} timed scopes in one frame (at '{}')", maxScopes_, name));
    }
    const auto scope = static_cast<uint32_t>(names_.size());
    names_.push_back(name);
    vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, pool_, 2 * scope);
    // lavapipe resolves a timestamp when it flushes; without this barrier a timestamp
    // followed by compute work reads late (PLATFORM.md). On a GPU it makes the scope
    // measure the pass alone rather than its overlap with the previous one.
    memoryBarrier(cmd, {VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, 0}, {VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, 0});
    return scope;
}

void GpuTimer::endScope(VkCommandBuffer cmd, uint32_t scope)
{
    vkCmdWriteTimestamp2(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, pool_, 2 * scope + 1);
}

std::vector<ScopeTime> GpuTimer::collect() const
{
    std::vector<ScopeTime> out;
    if (names_.empty()) return out;
    std::vector<uint64_t> ticks(2 * names_.size());
    check(vkGetQueryPoolResults(context_.device(), pool_, 0, static_cast<uint32_t>(ticks.size()),
                                ticks.size() * sizeof(uint64_t), ticks.data(), sizeof(uint64_t),
                                VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
          "vkGetQueryPoolResults (timestamps)");
    for (size_t i = 0; i < names_.size(); ++i) {
        // Masked difference: correct across a wrap of a counter narrower than 64 bits.
        const uint64_t delta = (ticks[2 * i + 1] - ticks[2 * i]) & validMask_;
        out.push_back({names_[i], double(delta) * nsPerTick_ * 1e-6});
    }
    return out;
}

} // namespace penumbra::gpu
