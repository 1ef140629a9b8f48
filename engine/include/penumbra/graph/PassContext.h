#pragma once
// The recording side of a render-graph pass (graph/RenderGraph.h ExecuteFn), on its own
// so that a plugin's callbacks need not see the executor (graph/GraphExecutor.h), which
// fills it in.
#include "penumbra/graph/RenderGraph.h"

#include <vulkan/vulkan.h>

#include <cstddef>
#include <span>
#include <string>
#include <string_view>

namespace penumbra::gpu {
class Buffer;
class Context;
class Image;
} // namespace penumbra::gpu

namespace penumbra::graph {

class GraphExecutor;

// What a pass's execute callback gets: the command buffer and the resources the pass
// declared, by name.
class PassContext {
public:
    // The command buffer being recorded; VK_NULL_HANDLE in a host pass, which records
    // nothing.
    VkCommandBuffer cmd() const { return cmd_; }
    gpu::Context& context() const { return *context_; }
    const std::string& passName() const { return *passName_; }

    // Throws penumbra::Error naming the pass when the pass did not declare `name` (a pass
    // may only touch what it declared: that is what its barriers were derived from).
    const gpu::Image& image(std::string_view name) const;
    const gpu::Buffer& buffer(std::string_view name) const;
    // The layout this pass declared for `name` (the executor put it there).
    VkImageLayout layout(std::string_view name) const;
    // Whether `name` is a marked output (RenderGraph::markOutput): it is read after the
    // frame (the frame's result, a debug image), so all of it matters, not only what the
    // passes after this one read.
    bool isOutput(std::string_view name) const;
    // Host passes: the mapped memory (host-visible, coherent) of a buffer the pass
    // declared with Usage::HostRead or HostWrite, its declared size. The GPU work before
    // the pass has finished and its writes are visible; what the pass writes is visible
    // to the GPU passes after it. Throws penumbra::Error naming the pass otherwise.
    std::span<std::byte> hostMemory(std::string_view name) const;

private:
    friend class GraphExecutor;
    VkCommandBuffer cmd_ = VK_NULL_HANDLE;
    gpu::Context* context_ = nullptr;
    const std::string* passName_ = nullptr;
    const GraphExecutor* executor_ = nullptr;
    const CompiledPass* pass_ = nullptr;
};

} // namespace penumbra::graph
