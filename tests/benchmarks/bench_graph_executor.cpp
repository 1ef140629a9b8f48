// Per-frame CPU cost of recording through the render graph executor versus recording the
// same commands and barriers by hand: a chain of 50 transfer passes over 256-byte
// buffers (pass 0 fills b0, pass i copies b(i-1) into b(i); b49 is the output). The
// graph aliases the chain into two memory slots, so its barriers are those of a
// hand-written ping-pong between two buffers: read-after-write on the source and
// write-after-read/write on the destination, one vkCmdPipelineBarrier2 per pass. Both
// sides record into the same command buffer (begin, 50 passes, end) and never submit:
// GPU execution is not part of the figure. The compiled graph and the transients are
// cached, as in a steady-state frame. Arg 1 adds GPU timestamps around every pass
// (gpu::GpuTimer) on both sides; the executor always adds a debug label (a no-op
// without validation) and a steady_clock reading around each callback.
//
//   cmake --build --preset release --target penumbra_benchmarks
//   build/release/tests/benchmarks/penumbra_benchmarks --benchmark_filter='Record' --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
//
// Figures (medians of 5, 2 shared cores, lavapipe, release), time per frame of 50 passes:
//   without timestamps: graph 12.5 us, by hand 9.3 us (≈ 65 ns of scheduling per pass);
//   with timestamps:    graph 21.8 us, by hand 17.9 us.
#include "penumbra/gpu/Check.h"
#include "penumbra/gpu/Context.h"
#include "penumbra/gpu/GpuTimer.h"
#include "penumbra/gpu/Resources.h"
#include "penumbra/graph/GraphExecutor.h"

#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include <array>

using namespace penumbra;

namespace {

constexpr uint32_t kPasses = 50;
constexpr VkDeviceSize kBytes = 256;

// One device for every benchmark in this file: creating a context takes far longer than
// the figures measured.
struct BenchDevice {
    BenchDevice() : context(gpu::ContextOptions{{}, false})
    {
        VkCommandBufferAllocateInfo info{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
        info.commandPool = context.commandPool();  // created with RESET_COMMAND_BUFFER
        info.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
        info.commandBufferCount = 1;
        gpu::check(vkAllocateCommandBuffers(context.device(), &info, &cmd), "vkAllocateCommandBuffers (benchmark)");
    }
    ~BenchDevice() { vkFreeCommandBuffers(context.device(), context.commandPool(), 1, &cmd); }

    // vkBeginCommandBuffer resets the buffer implicitly (the pool allows it).
    template <typename Record>
    void recordFrame(Record&& record)
    {
        VkCommandBufferBeginInfo begin{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
        begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
        gpu::check(vkBeginCommandBuffer(cmd, &begin), "vkBeginCommandBuffer (benchmark)");
        record(cmd);
        gpu::check(vkEndCommandBuffer(cmd), "vkEndCommandBuffer (benchmark)");
    }

    gpu::Context context;
    VkCommandBuffer cmd = VK_NULL_HANDLE;
};

BenchDevice& device()
{
    static BenchDevice instance;
    return instance;
}

std::string bufferName(uint32_t i) { return fmt::format("b{}", i); }

void BM_GraphRecord(benchmark::State& state)
{
    BenchDevice& dev = device();
    graph::RenderGraph graph;
    std::vector<std::string> names;
    for (uint32_t i = 0; i < kPasses; ++i) {
        names.push_back(bufferName(i));
        graph.declareBuffer({names.back(), kBytes, false});
    }
    graph.addPass("pass0", graph::QueueKind::Transfer)
        .write(names[0], graph::Usage::TransferDst)
        .execute([&](graph::PassContext& pass) {
            vkCmdFillBuffer(pass.cmd(), pass.buffer(names[0]).handle(), 0, kBytes, 1);
        });
    for (uint32_t i = 1; i < kPasses; ++i)
        graph.addPass(fmt::format("pass{}", i), graph::QueueKind::Transfer)
            .read(names[i - 1], graph::Usage::TransferSrc)
            .write(names[i], graph::Usage::TransferDst)
            .execute([&, i](graph::PassContext& pass) {
                const VkBufferCopy region{0, 0, kBytes};
                vkCmdCopyBuffer(pass.cmd(), pass.buffer(names[i - 1]).handle(), pass.buffer(names[i]).handle(), 1,
                                &region);
            });
    graph.markOutput(names.back());

    graph::GraphExecutor executor(dev.context, graph::ExecutorOptions{state.range(0) != 0});
    dev.recordFrame([&](VkCommandBuffer cmd) { executor.record(cmd, graph); });  // compile + transients
    for (auto _ : state) dev.recordFrame([&](VkCommandBuffer cmd) { executor.record(cmd, graph); });
    state.counters["slots"] = double(executor.compiled()->memorySlots.size());
}
BENCHMARK(BM_GraphRecord)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

void bufferBarrier(VkCommandBuffer cmd, VkBuffer source, VkBuffer target, bool targetUsedBefore)
{
    std::array<VkBufferMemoryBarrier2, 2> barriers{};
    for (VkBufferMemoryBarrier2& b : barriers) {
        b.sType = VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER_2;
        b.srcStageMask = VK_PIPELINE_STAGE_2_TRANSFER_BIT;
        b.srcAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
        b.dstStageMask = VK_PIPELINE_STAGE_2_TRANSFER_BIT;
        b.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        b.size = VK_WHOLE_SIZE;
    }
    barriers[0].buffer = source;  // read after write
    barriers[0].dstAccessMask = VK_ACCESS_2_TRANSFER_READ_BIT;
    barriers[1].buffer = target;  // write after the read and the write two passes ago
    barriers[1].dstAccessMask = VK_ACCESS_2_TRANSFER_WRITE_BIT;
    VkDependencyInfo dependency{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
    dependency.bufferMemoryBarrierCount = targetUsedBefore ? 2 : 1;
    dependency.pBufferMemoryBarriers = barriers.data();
    vkCmdPipelineBarrier2(cmd, &dependency);
}

void BM_ByHandRecord(benchmark::State& state)
{
    BenchDevice& dev = device();
    const VkBufferUsageFlags usage = VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    const std::array<gpu::Buffer, 2> pingPong{gpu::Buffer(dev.context, kBytes, usage, false, "ping"),
                                              gpu::Buffer(dev.context, kBytes, usage, false, "pong")};
    const bool timed = state.range(0) != 0;
    gpu::GpuTimer timer(dev.context, kPasses);
    std::vector<std::string> passNames;
    for (uint32_t i = 0; i < kPasses; ++i) passNames.push_back(fmt::format("pass{}", i));

    auto record = [&](VkCommandBuffer cmd) {
        if (timed) timer.beginFrame(cmd);
        for (uint32_t i = 0; i < kPasses; ++i) {
            const VkBuffer target = pingPong[i % 2].handle();
            if (i > 0) bufferBarrier(cmd, pingPong[(i - 1) % 2].handle(), target, i > 1);
            const uint32_t scope = timed ? timer.beginScope(cmd, passNames[i]) : 0;
            if (i == 0) {
                vkCmdFillBuffer(cmd, target, 0, kBytes, 1);
            } else {
                const VkBufferCopy region{0, 0, kBytes};
                vkCmdCopyBuffer(cmd, pingPong[(i - 1) % 2].handle(), target, 1, &region);
            }
            if (timed) timer.endScope(cmd, scope);
        }
    };
    for (auto _ : state) dev.recordFrame(record);
}
BENCHMARK(BM_ByHandRecord)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

} // namespace
