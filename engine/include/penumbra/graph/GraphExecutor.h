#pragma once
// Executes a compiled render graph on a device (Granite's "execute" step): creates the
// transient images and buffers, places those that share a memory slot in one block of
// device memory (aliasing, sized from vkGet*MemoryRequirements), records every executed
// pass as: its barriers (one vkCmdPipelineBarrier2) -> debug label -> GPU timestamp ->
// the pass's execute callback (CPU-timed) -> timestamp -> end label. Culled passes are
// never called. Imported resources are bound by the caller before recording.
#include "penumbra/graph/RenderGraph.h"

#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra::gpu {
class Buffer;
class Context;
class Image;
} // namespace penumbra::gpu

namespace penumbra::graph {

// What a pass's execute callback gets: the command buffer and the resources the pass
// declared, by name.
class PassContext {
public:
    VkCommandBuffer cmd() const { return cmd_; }
    gpu::Context& context() const { return *context_; }
    const std::string& passName() const { return *passName_; }

    // Throws penumbra::Error naming the pass when the pass did not declare `name` (a pass
    // may only touch what it declared: that is what its barriers were derived from).
    const gpu::Image& image(std::string_view name) const;
    const gpu::Buffer& buffer(std::string_view name) const;
    // The layout this pass declared for `name` (the executor put it there).
    VkImageLayout layout(std::string_view name) const;

private:
    friend class GraphExecutor;
    VkCommandBuffer cmd_ = VK_NULL_HANDLE;
    gpu::Context* context_ = nullptr;
    const std::string* passName_ = nullptr;
    const class GraphExecutor* executor_ = nullptr;
    const CompiledPass* pass_ = nullptr;
};

struct PassTiming {
    std::string name;
    double gpuMs = 0.0;  // 0 when GPU timestamps are off
    double cpuMs = 0.0;  // time the execute callback took to record
};

// What one transient resource takes on its own (vkGet*MemoryRequirements, size rounded
// up to its alignment): the figure for "memory per technique". Aliasing may place it in
// memory shared with others, so these add up to transientBytesWithoutAliasing().
struct TransientMemory {
    std::string name;
    VkDeviceSize bytes = 0;
};

struct ExecutorOptions {
    // Timestamps around every pass. gpu::GpuTimer follows each start timestamp with an
    // execution barrier over all commands (lavapipe reads late without it), which also
    // orders every pass after all earlier ones: tests that check the graph's own barriers
    // with synchronization validation turn timestamps off so that nothing hides a missing
    // dependency.
    bool gpuTimestamps = true;
};

class GraphExecutor {
public:
    explicit GraphExecutor(gpu::Context& context, ExecutorOptions options = {});
    ~GraphExecutor();
    GraphExecutor(const GraphExecutor&) = delete;
    GraphExecutor& operator=(const GraphExecutor&) = delete;

    // Binds an imported resource (declared with imported = true) to its owner's object,
    // which must outlive the executor's use of it. Rebinding replaces the binding.
    void bindImage(std::string_view name, const gpu::Image& image);
    void bindBuffer(std::string_view name, const gpu::Buffer& buffer);

    // Compiles `graph` (cached while unchanged), (re)creates the transient resources when
    // the compiled graph changed (after waiting for the device to go idle: the previous
    // frame may still use the old ones), and records every executed pass into `cmd` (which must
    // be recording, outside a render pass). Imported images whose declared initialLayout
    // is not UNDEFINED are returned to it after the last pass, so each frame starts from
    // the declared state. Throws penumbra::Error naming the pass or resource on misuse
    // (an unbound or mismatched import, an executed pass without a callback, a callback
    // that throws); `cmd` is then left partly recorded and must not be submitted.
    void record(VkCommandBuffer cmd, RenderGraph& graph);

    // After the recorded command buffer finished: GPU and CPU time per executed pass, in
    // execution order.
    std::vector<PassTiming> collectTimings() const;

    // The compiled graph last recorded (null before the first record).
    const std::shared_ptr<const CompiledGraph>& compiled() const { return compiled_; }

    // A resource of the last recorded graph (transient or imported) and the layout it is
    // in after the frame: for reading marked outputs back. Throws for unknown names and
    // for resources that no executed pass uses (they have no object).
    const gpu::Image& image(std::string_view name) const;
    const gpu::Buffer& buffer(std::string_view name) const;
    VkImageLayout finalLayout(std::string_view name) const;

    // Device memory actually allocated for transient resources (after aliasing), and what
    // the same resources would take with one allocation each.
    VkDeviceSize transientBytesAllocated() const;
    VkDeviceSize transientBytesWithoutAliasing() const;
    // Each transient resource of the last recorded graph that an executed pass uses, in
    // declaration order (empty before the first record).
    std::vector<TransientMemory> transientMemory() const;

private:
    friend class PassContext;
    struct State;
    std::unique_ptr<State> state_;
    std::shared_ptr<const CompiledGraph> compiled_;
};

} // namespace penumbra::graph
