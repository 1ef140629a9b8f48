#pragma once
// Executes a compiled render graph on a device (Granite's "execute" step): creates the
// transient images and buffers, places those that share a memory slot in one block of
// device memory (aliasing, sized from vkGet*MemoryRequirements), records every executed
// GPU pass as: its barriers (one vkCmdPipelineBarrier2) -> debug label -> GPU timestamp
// -> the pass's execute callback (CPU-timed) -> timestamp -> end label. Host passes
// split the frame: the GPU passes before one are submitted and waited for, its callback
// runs on the CPU (timed), and recording goes on in the next submission. Culled passes
// are never called. Imported resources are bound by the caller before execution.
#include "penumbra/graph/PassContext.h"
#include "penumbra/graph/RenderGraph.h"

#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra::graph {

struct PassTiming {
    std::string name;
    double gpuMs = 0.0;  // 0 when GPU timestamps are off, and for host passes
    double cpuMs = 0.0;  // time the execute callback took: recording, or a host pass's work
    // Not run: its results were kept from an earlier frame (CompiledPass::keptWhile).
    bool kept = false;
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

    // Runs one frame of `graph` and returns when the device has finished it: compiles
    // (cached while unchanged), (re)creates the transient resources when the compiled
    // graph changed (after waiting for the device to go idle: the previous frame may
    // still use the old ones), records the executed GPU passes into the executor's own
    // command buffer and submits it, splitting the frame at every host pass (record the
    // passes before it, submit, wait, run its callback, record on). Imported images whose
    // declared initialLayout is not UNDEFINED are returned to it after the last pass, so
    // each frame starts from the declared state. Throws penumbra::Error naming the pass
    // or resource on misuse (an unbound or mismatched import, an executed pass without a
    // callback, a callback that throws); the frame's remaining passes then do not run.
    //
    // A pass that may be kept (CompiledPass::keptWhile) is not run, only its barriers
    // recorded, when it ran in an earlier frame with the resources as they are, every
    // state it depends on has the version it had then (RenderGraph::setState), and no
    // pass that runs this frame writes a resource it reads or writes. Its results are
    // then what that run left. A frame that throws forgets every run.
    void execute(RenderGraph& graph);

    // Records the whole frame into `cmd` (recording, outside a render pass) without
    // submitting it, for a caller that submits the frame with other work or measures
    // recording alone. Only for graphs without executed host passes (those need the
    // submissions execute() makes): throws penumbra::Error naming the host pass. Errors
    // as for execute(); `cmd` is then left partly recorded and must not be submitted.
    void record(VkCommandBuffer cmd, RenderGraph& graph);

    // After the frame finished (execute(), or record() and the caller's submission): GPU
    // and CPU time per executed pass, in execution order.
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
    // Each imported resource of the last recorded graph that an executed pass uses, with
    // the memory of the object bound to it (a technique's persistent atlas, its tables).
    std::vector<TransientMemory> importedMemory() const;

private:
    friend class PassContext;
    struct DeviceResources;
    const CompiledGraph& prepare(RenderGraph& graph);
    void recordGpuPass(VkCommandBuffer cmd, RenderGraph& graph, size_t index);
    void runHostPass(RenderGraph& graph, size_t index);
    std::unique_ptr<DeviceResources> resources_;
    std::shared_ptr<const CompiledGraph> compiled_;
};

} // namespace penumbra::graph
