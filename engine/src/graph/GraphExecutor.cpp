#include "penumbra/graph/GraphExecutor.h"

#include "core/Clock.h"
#include "graph/Align.h"
#include "penumbra/core/Error.h"
#include "penumbra/gpu/Check.h"
#include "penumbra/gpu/Context.h"
#include "penumbra/gpu/GpuTimer.h"
#include "penumbra/gpu/Resources.h"

#include <fmt/format.h>
#include <vulkan/vulkan.hpp>
#include <vulkan/vulkan_to_string.hpp>

#include <algorithm>
#include <chrono>
#include <map>
#include <optional>

namespace penumbra::graph {

namespace {

// A layout transition of a combined depth/stencil image must name both aspects (the
// engine does not use separateDepthStencilLayouts).
VkImageAspectFlags barrierAspect(VkFormat format)
{
    switch (format) {
    case VK_FORMAT_D16_UNORM_S8_UINT:
    case VK_FORMAT_D24_UNORM_S8_UINT:
    case VK_FORMAT_D32_SFLOAT_S8_UINT: return VK_IMAGE_ASPECT_DEPTH_BIT | VK_IMAGE_ASPECT_STENCIL_BIT;
    case VK_FORMAT_S8_UINT: return VK_IMAGE_ASPECT_STENCIL_BIT;
    default: return gpu::isDepthFormat(format) ? VK_IMAGE_ASPECT_DEPTH_BIT : VK_IMAGE_ASPECT_COLOR_BIT;
    }
}

const char* kindName(const CompiledResource& res) { return res.isImage ? "image" : "buffer"; }

// How an out-of-memory message names a transient: its size and the pass that first
// writes it (whose technique's parameters set that size).
std::string describeResource(const CompiledGraph& graph, uint32_t r)
{
    const CompiledResource& res = graph.resources[r];
    const std::string size = res.isImage ? fmt::format("{} x {}{} {}", res.width, res.height,
                                                       res.layers > 1 ? fmt::format(" x {} layers", res.layers) : "",
                                                       gpu::formatName(res.format))
                                         : fmt::format("{} bytes", uint64_t(res.sizeBytes));
    const std::string pass = res.firstUse >= 0 && size_t(res.firstUse) < graph.passes.size()
                                 ? fmt::format(", first used by pass '{}'", graph.passes[size_t(res.firstUse)].name)
                                 : "";
    return fmt::format("render graph {} '{}' ({}{})", kindName(res), res.name, size, pass);
}

// The executed passes that use resource `r`, for error messages: "'a', 'b'".
std::string passesUsing(const CompiledGraph& graph, uint32_t r)
{
    std::string names;
    for (const CompiledPass& pass : graph.passes)
        for (const ResourceUse& use : pass.uses)
            if (use.resource == r) names += fmt::format("{}'{}'", names.empty() ? "" : ", ", pass.name);
    return names;
}

const ResourceUse& declaredUse(const CompiledGraph& graph, const CompiledPass& pass, std::string_view name)
{
    for (const ResourceUse& use : pass.uses)
        if (graph.resources[use.resource].name == name) return use;
    const bool exists = std::any_of(graph.resources.begin(), graph.resources.end(),
                                    [&](const CompiledResource& res) { return res.name == name; });
    throw Error(fmt::format("render graph: pass '{}' uses '{}', which it did not declare{}; declare it with "
                            "read() or write() (its barriers are derived from the declarations)",
                            pass.name, name, exists ? "" : " (no resource of that name exists)"));
}

} // namespace

// What the executor keeps on the device from frame to frame: the objects behind every
// resource (transient images and buffers with their memory, bound imports), the command
// buffer and timers it records with, and the last frame's timings.
struct GraphExecutor::DeviceResources {
    DeviceResources(gpu::Context& context, ExecutorOptions options) : context(context), options(options) {}
    ~DeviceResources()
    {
        releaseTransients();
        if (cmd) vkFreeCommandBuffers(context.device(), context.commandPool(), 1, &cmd);
    }
    DeviceResources(const DeviceResources&) = delete;
    DeviceResources& operator=(const DeviceResources&) = delete;

    gpu::Context& context;
    ExecutorOptions options;
    std::map<std::string, const gpu::Image*, std::less<>> boundImages;
    std::map<std::string, const gpu::Buffer*, std::less<>> boundBuffers;

    // Per compiled graph, indexed like CompiledGraph::resources (empty objects for
    // imported and unused resources).
    std::vector<gpu::Image> transientImages;
    std::vector<gpu::Buffer> transientBuffers;
    std::vector<VkDeviceMemory> memory;
    // Per resource: the start of its mapped memory (host-visible buffers), else null.
    std::vector<std::byte*> hostPointers;
    VkDeviceSize bytesAllocated = 0;
    VkDeviceSize bytesWithoutAliasing = 0;
    std::vector<TransientMemory> transientMemory;  // what each created transient requires
    std::map<std::string, uint32_t, std::less<>> resourceIndex;

    // The object behind every resource the executed passes use; imports are resolved
    // again every frame, since they may be rebound between frames.
    std::vector<const gpu::Image*> images;
    std::vector<const gpu::Buffer*> buffers;

    std::unique_ptr<gpu::GpuTimer> timer;
    uint32_t timerScopes = 0;
    bool timed = false;              // this frame has GPU timestamps
    std::vector<double> cpuMs;       // per executed pass of the last frame
    std::vector<int> timerScope;     // per executed pass: its GPU timestamp scope, -1 for none
    bool frameRecorded = false;
    VkCommandBuffer cmd = VK_NULL_HANDLE;  // execute()'s, reused by every segment
    // Per pass of the compiled graph: the versions of its states when it last ran with
    // the present resources (nullopt: it has not, or it runs every frame), those of this
    // frame, and whether it runs this frame.
    std::vector<std::optional<std::vector<uint64_t>>> ranWith;
    std::vector<std::optional<std::vector<uint64_t>>> frameVersions;
    std::vector<char> runs;
    std::vector<char> kept;  // per executed pass of the last frame, in order: not run
    // New persistent images, to be put in the layout a frame starts them in before the
    // next frame's passes (barriers from UNDEFINED).
    std::vector<Barrier> newPersistent;
    // The names of the GPU passes recorded into the open segment (the compiled graph's:
    // valid while it executes; the vector keeps its capacity, so a frame allocates nothing).
    std::vector<const std::string*> segmentPasses;

    struct Block {
        VkDeviceMemory memory = VK_NULL_HANDLE;
        std::byte* mapped = nullptr;  // host-visible blocks only
    };

    // Reused between frames so that recording barriers allocates nothing.
    std::vector<VkImageMemoryBarrier2> imageBarriers;
    std::vector<VkBufferMemoryBarrier2> bufferBarriers;

    void createTransients(const CompiledGraph& graph);
    void placeSlot(const CompiledGraph& graph, uint32_t slot, const std::vector<VkMemoryRequirements>& requirements);
    Block allocate(VkDeviceSize size, uint32_t typeBits, bool hostVisible, const std::string& name);
    void bind(const CompiledGraph& graph, uint32_t r, const Block& block);
    void beginSegment();
    void submitSegment();
    void releaseTransients();
    void resolveImports(const CompiledGraph& graph);
    void recordBarriers(VkCommandBuffer cmd, const CompiledGraph& graph, const std::vector<Barrier>& barriers);
    void decideRuns(const RenderGraph& graph, const CompiledGraph& compiled);
    // After a frame was recorded whole: what ran is what the resources hold now, and the
    // new persistent images have their layout.
    void rememberRuns()
    {
        for (size_t i = 0; i < runs.size(); ++i)
            if (runs[i]) ranWith[i] = frameVersions[i];
        newPersistent.clear();
    }
    // A frame that failed part way: none of its results are kept.
    void forgetRuns() { std::fill(ranWith.begin(), ranWith.end(), std::nullopt); }
    void recordKept(VkCommandBuffer cmd, const CompiledGraph& graph, const CompiledPass& pass);
};

void GraphExecutor::DeviceResources::releaseTransients()
{
    // Objects before the memory they are bound to.
    transientImages.clear();
    transientBuffers.clear();
    // Freeing mapped memory unmaps it.
    for (VkDeviceMemory block : memory) vkFreeMemory(context.device(), block, nullptr);
    memory.clear();
    hostPointers.clear();
    bytesAllocated = 0;
    bytesWithoutAliasing = 0;
    transientMemory.clear();
}

void GraphExecutor::DeviceResources::createTransients(const CompiledGraph& graph)
{
    // The previous frame's command buffer may still read the resources being replaced.
    // This happens only when the graph's declaration changed, so a full wait is cheap.
    if (!memory.empty())
        gpu::check(vkDeviceWaitIdle(context.device()), "vkDeviceWaitIdle (render graph: replacing transients)");
    releaseTransients();
    const size_t count = graph.resources.size();
    transientImages.resize(count);
    transientBuffers.resize(count);
    images.assign(count, nullptr);
    buffers.assign(count, nullptr);
    hostPointers.assign(count, nullptr);
    resourceIndex.clear();

    std::vector<VkMemoryRequirements> requirements(count);
    for (uint32_t r = 0; r < count; ++r) {
        const CompiledResource& res = graph.resources[r];
        resourceIndex.emplace(res.name, r);
        if (res.imported || res.firstUse < 0) continue;
        try {
            if (res.isImage) {
                transientImages[r] = gpu::Image::createUnbound(
                    context, {res.width, res.height, res.format, res.imageUsage, res.name, res.layers});
                requirements[r] = transientImages[r].memoryRequirements();
                images[r] = &transientImages[r];
            } else {
                transientBuffers[r] = gpu::Buffer::createUnbound(context, res.sizeBytes, res.bufferUsage, res.name);
                requirements[r] = transientBuffers[r].memoryRequirements();
                buffers[r] = &transientBuffers[r];
            }
        } catch (const Error& e) {
            throw GpuError(fmt::format("render graph: transient {} '{}': {}", kindName(res), res.name, e.what()));
        }
        transientMemory.push_back({res.name, alignUp(requirements[r].size, requirements[r].alignment)});
        bytesWithoutAliasing += transientMemory.back().bytes;
    }
    for (uint32_t s = 0; s < graph.memorySlots.size(); ++s) placeSlot(graph, s, requirements);
    ranWith.assign(graph.passes.size(), std::nullopt);
    newPersistent.clear();
    std::vector<VkImageLayout> startLayout(count, VK_IMAGE_LAYOUT_UNDEFINED);
    for (const CompiledPass& pass : graph.passes)
        for (const ResourceUse& use : pass.uses) startLayout[use.resource] = use.scope.layout;
    for (uint32_t r = 0; r < count; ++r) {
        const CompiledResource& res = graph.resources[r];
        if (!res.persistent || !res.isImage || res.firstUse < 0 || startLayout[r] == VK_IMAGE_LAYOUT_UNDEFINED) continue;
        newPersistent.push_back(Barrier{r, true, VK_IMAGE_LAYOUT_UNDEFINED, startLayout[r], VK_PIPELINE_STAGE_2_NONE,
                                        VK_ACCESS_2_NONE, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                                        VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT});
    }
    // compile() puts every used transient in a slot; should one be missing, it still
    // gets memory rather than an unbound object.
    for (uint32_t r = 0; r < count; ++r) {
        const CompiledResource& res = graph.resources[r];
        if (res.imported || res.firstUse < 0 || res.memorySlot >= 0) continue;
        bind(graph, r,
             allocate(requirements[r].size, requirements[r].memoryTypeBits, res.hostVisible, describeResource(graph, r)));
    }
}

// One allocation for the slot's members, sized from the real requirements: the largest
// member, rounded to the largest alignment (all are bound at offset 0, where every
// alignment holds). The compiler's slot sizes are estimates and are not used here.
void GraphExecutor::DeviceResources::placeSlot(const CompiledGraph& graph, uint32_t slot,
                                               const std::vector<VkMemoryRequirements>& requirements)
{
    const bool hostVisible = graph.memorySlots[slot].hostVisible;
    std::vector<uint32_t> shared;
    uint32_t typeBits = ~0u;
    VkDeviceSize size = 0;
    VkDeviceSize alignment = 1;
    std::string names;
    for (uint32_t r : graph.memorySlots[slot].resources) {
        const VkMemoryRequirements& req = requirements[r];
        if ((typeBits & req.memoryTypeBits) == 0) {
            // No memory type can hold this member and the ones before it (a driver may keep,
            // say, depth images in a type of their own): it gets its own allocation. It
            // still shares nothing with a live resource, so correctness is unaffected;
            // only the saving is lost.
            bind(graph, r, allocate(req.size, req.memoryTypeBits, hostVisible, describeResource(graph, r)));
            continue;
        }
        typeBits &= req.memoryTypeBits;
        size = std::max(size, req.size);
        alignment = std::max(alignment, req.alignment);
        shared.push_back(r);
        names += fmt::format("{}{}", names.empty() ? "" : "; ", describeResource(graph, r));
    }
    if (shared.empty()) return;
    const Block block = allocate(alignUp(size, alignment), typeBits, hostVisible,
                                 fmt::format("render graph memory slot {}, shared by: {}", slot, names));
    for (uint32_t r : shared) bind(graph, r, block);
}

// Host-visible blocks are coherent (no flush or invalidate around host passes) and
// preferably cached (host passes read what the GPU wrote); they stay mapped while they
// live.
GraphExecutor::DeviceResources::Block GraphExecutor::DeviceResources::allocate(VkDeviceSize size, uint32_t typeBits,
                                                                               bool hostVisible, const std::string& name)
{
    VkMemoryAllocateInfo info{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
    info.allocationSize = size;
    info.memoryTypeIndex =
        hostVisible ? context.findMemoryType(typeBits,
                                             VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT,
                                             VK_MEMORY_PROPERTY_HOST_CACHED_BIT)
                    : context.findMemoryType(typeBits, 0, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    Block block;
    block.memory = context.allocateMemory(info, name,
                                          "lower what sets the size of the pass's images (its technique's resolution "
                                          "parameter, or the output's --width/--height)");
    memory.push_back(block.memory);
    bytesAllocated += size;
    context.setName(VK_OBJECT_TYPE_DEVICE_MEMORY, reinterpret_cast<uint64_t>(block.memory), name);
    if (hostVisible) {
        void* mapped = nullptr;
        gpu::check(vkMapMemory(context.device(), block.memory, 0, VK_WHOLE_SIZE, 0, &mapped),
                   fmt::format("vkMapMemory ({} bytes for {})", size, name));
        block.mapped = static_cast<std::byte*>(mapped);
    }
    return block;
}

void GraphExecutor::DeviceResources::bind(const CompiledGraph& graph, uint32_t r, const Block& block)
{
    const CompiledResource& res = graph.resources[r];
    try {
        if (res.isImage) transientImages[r].bindMemory(block.memory, 0);
        else transientBuffers[r].bindMemory(block.memory, 0);
    } catch (const Error& e) {
        throw GpuError(fmt::format("render graph: transient {} '{}': {}", kindName(res), res.name, e.what()));
    }
    hostPointers[r] = block.mapped;
}

void GraphExecutor::DeviceResources::beginSegment()
{
    // A callback that threw may have left the buffer recording: reset it either way.
    gpu::check(vkResetCommandBuffer(cmd, 0), "vkResetCommandBuffer (render graph)");
    VkCommandBufferBeginInfo begin{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    gpu::check(vkBeginCommandBuffer(cmd, &begin), "vkBeginCommandBuffer (render graph)");
    segmentPasses.clear();
}

void GraphExecutor::DeviceResources::submitSegment()
{
    gpu::check(vkEndCommandBuffer(cmd), "vkEndCommandBuffer (render graph)");
    try {
        context.submitAndWait(cmd);
    } catch (const gpu::VulkanError& e) {
        if (e.result() != VK_ERROR_DEVICE_LOST) throw;
        // A lost device cannot say where it failed (no checkpoints on every driver): the
        // passes of the submission are the suspects, and isolation narrows them to one.
        std::string passes;
        for (const std::string* name : segmentPasses) passes += fmt::format("{}'{}'", passes.empty() ? "" : ", ", *name);
        if (segmentPasses.size() == 1) {
            throw gpu::VulkanError(fmt::format("the device was lost running render graph pass {}: the driver crashed or "
                                               "the pass faulted or hung ({})",
                                               passes, e.what()),
                                   e.result());
        }
        throw gpu::VulkanError(
            fmt::format("the device was lost in a submission of render graph passes {}: the driver crashed or one of them "
                        "faulted or hung; PENUMBRA_ISOLATE_PASSES=1 submits each pass alone to name it ({})",
                        passes.empty() ? "(none: barriers only)" : passes, e.what()),
            e.result());
    }
}

void GraphExecutor::DeviceResources::resolveImports(const CompiledGraph& graph)
{
    for (uint32_t r = 0; r < graph.resources.size(); ++r) {
        const CompiledResource& res = graph.resources[r];
        if (!res.imported || res.firstUse < 0) continue;
        const auto missing = [&] {
            return Error(fmt::format("render graph: imported {} '{}' is not bound (used by {}); call "
                                     "GraphExecutor::bind{}() before execute()",
                                     kindName(res), res.name, passesUsing(graph, r), res.isImage ? "Image" : "Buffer"));
        };
        if (res.isImage) {
            const auto found = boundImages.find(res.name);
            if (found == boundImages.end()) throw missing();
            const gpu::ImageDesc& desc = found->second->desc();
            if (desc.width != res.width || desc.height != res.height || desc.format != res.format ||
                desc.layers != res.layers)
                throw Error(fmt::format("render graph: imported image '{}' is declared {}x{}x{} {} but the bound "
                                        "image '{}' is {}x{}x{} {}",
                                        res.name, res.width, res.height, res.layers,
                                        vk::to_string(vk::Format(res.format)), desc.name, desc.width, desc.height,
                                        desc.layers, vk::to_string(vk::Format(desc.format))));
            if ((desc.usage & res.imageUsage) != res.imageUsage)
                throw Error(fmt::format("render graph: imported image '{}': the bound image lacks usage {} (needed "
                                        "by the passes {}{})",
                                        res.name, vk::to_string(vk::ImageUsageFlags(res.imageUsage & ~desc.usage)),
                                        passesUsing(graph, r),
                                        res.markedOutput ? " and for reading the marked output back" : ""));
            images[r] = found->second;
        } else {
            const auto found = boundBuffers.find(res.name);
            if (found == boundBuffers.end()) throw missing();
            if (found->second->size() < res.sizeBytes)
                throw Error(fmt::format("render graph: imported buffer '{}' is declared {} bytes but the bound "
                                        "buffer has {}",
                                        res.name, res.sizeBytes, found->second->size()));
            if (res.readBack && !found->second->mapped())
                throw Error(fmt::format("render graph: imported buffer '{}' is read back by the host "
                                        "(RenderGraph::readBack) but the bound buffer is not host-visible; create "
                                        "it with hostVisible = true",
                                        res.name));
            if (res.hostVisible && !found->second->mapped())
                throw Error(fmt::format("render graph: imported buffer '{}' is used by the host passes {} but the "
                                        "bound buffer is not host-visible; create it with hostVisible = true",
                                        res.name, passesUsing(graph, r)));
            buffers[r] = found->second;
            hostPointers[r] = static_cast<std::byte*>(found->second->mapped());
        }
    }
}

void GraphExecutor::DeviceResources::recordBarriers(VkCommandBuffer cmd, const CompiledGraph& graph,
                                                    const std::vector<Barrier>& barriers)
{
    if (barriers.empty()) return;
    imageBarriers.clear();
    bufferBarriers.clear();
    for (const Barrier& b : barriers) {
        if (b.isImage) {
            VkImageMemoryBarrier2& out = imageBarriers.emplace_back(VkImageMemoryBarrier2{
                VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2});
            out.srcStageMask = b.srcStage;
            out.srcAccessMask = b.srcAccess;
            out.dstStageMask = b.dstStage;
            out.dstAccessMask = b.dstAccess;
            out.oldLayout = b.oldLayout;
            out.newLayout = b.newLayout;
            out.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
            out.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
            out.image = images[b.resource]->handle();
            out.subresourceRange = {barrierAspect(graph.resources[b.resource].format), 0, 1, 0, VK_REMAINING_ARRAY_LAYERS};
        } else {
            VkBufferMemoryBarrier2& out = bufferBarriers.emplace_back(VkBufferMemoryBarrier2{
                VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER_2});
            out.srcStageMask = b.srcStage;
            out.srcAccessMask = b.srcAccess;
            out.dstStageMask = b.dstStage;
            out.dstAccessMask = b.dstAccess;
            out.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
            out.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
            out.buffer = buffers[b.resource]->handle();
            out.offset = 0;
            out.size = VK_WHOLE_SIZE;
        }
    }
    VkDependencyInfo dependency{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
    dependency.imageMemoryBarrierCount = uint32_t(imageBarriers.size());
    dependency.pImageMemoryBarriers = imageBarriers.data();
    dependency.bufferMemoryBarrierCount = uint32_t(bufferBarriers.size());
    dependency.pBufferMemoryBarriers = bufferBarriers.data();
    vkCmdPipelineBarrier2(cmd, &dependency);
}

// Which passes run this frame: every pass, except one that may be kept, ran with these
// resources, sees the versions of its states it ran with, and shares no resource with a
// pass that writes it this frame (a pass that runs writes what its readers read, and
// what another writer of the same resource would then overwrite or build on).
void GraphExecutor::DeviceResources::decideRuns(const RenderGraph& graph, const CompiledGraph& compiled)
{
    const size_t count = compiled.passes.size();
    runs.assign(count, 1);
    frameVersions.assign(count, std::nullopt);
    for (size_t i = 0; i < count; ++i) {
        const CompiledPass& pass = compiled.passes[i];
        if (pass.keptWhile.empty()) continue;
        std::vector<uint64_t> versions;
        for (const std::string& state : pass.keptWhile) {
            const std::optional<uint64_t> version = graph.stateVersion(state);
            if (!version) break;
            versions.push_back(*version);
        }
        if (versions.size() != pass.keptWhile.size()) continue;
        runs[i] = !(ranWith[i] && *ranWith[i] == versions);
        frameVersions[i] = std::move(versions);
    }
    std::vector<char> written(compiled.resources.size());
    for (bool more = true; more;) {
        more = false;
        std::fill(written.begin(), written.end(), 0);
        for (size_t i = 0; i < count; ++i)
            if (runs[i])
                for (const ResourceUse& use : compiled.passes[i].uses) written[use.resource] |= char(use.writes);
        for (size_t i = 0; i < count; ++i) {
            if (runs[i]) continue;
            const auto& uses = compiled.passes[i].uses;
            if (std::any_of(uses.begin(), uses.end(), [&](const ResourceUse& use) { return written[use.resource] != 0; })) {
                runs[i] = 1;
                more = true;
            }
        }
    }
}

// A kept pass: its barriers still move its resources through the layouts the passes
// after it expect (a transition from a defined layout keeps the contents).
void GraphExecutor::DeviceResources::recordKept(VkCommandBuffer cmd, const CompiledGraph& graph, const CompiledPass& pass)
{
    recordBarriers(cmd, graph, pass.barriersBefore);
    cpuMs.push_back(0.0);
    timerScope.push_back(-1);
    kept.push_back(1);
}

// ---------------------------------------------------------------------------------------
// PassContext

const gpu::Image& PassContext::image(std::string_view name) const
{
    const ResourceUse& use = declaredUse(*executor_->compiled_, *pass_, name);
    const gpu::Image* object = executor_->resources_->images[use.resource];
    if (!object)
        throw Error(fmt::format("render graph: pass '{}' asks for image '{}', which is a buffer", *passName_, name));
    return *object;
}

const gpu::Buffer& PassContext::buffer(std::string_view name) const
{
    const ResourceUse& use = declaredUse(*executor_->compiled_, *pass_, name);
    const gpu::Buffer* object = executor_->resources_->buffers[use.resource];
    if (!object)
        throw Error(fmt::format("render graph: pass '{}' asks for buffer '{}', which is an image", *passName_, name));
    return *object;
}

std::span<std::byte> PassContext::hostMemory(std::string_view name) const
{
    const ResourceUse& use = declaredUse(*executor_->compiled_, *pass_, name);
    if (pass_->queue != QueueKind::Host)
        throw Error(fmt::format("render graph: pass '{}' asks for the host memory of '{}' but is not a host pass "
                                "(the GPU may be using that memory while it records)",
                                *passName_, name));
    std::byte* mapped = executor_->resources_->hostPointers[use.resource];
    if (!mapped)
        throw Error(fmt::format("render graph: pass '{}' asks for the host memory of '{}', which is not a "
                                "host-visible buffer",
                                *passName_, name));
    return {mapped, size_t(executor_->compiled_->resources[use.resource].sizeBytes)};
}

bool PassContext::isOutput(std::string_view name) const
{
    const ResourceUse& use = declaredUse(*executor_->compiled_, *pass_, name);
    return executor_->compiled_->resources[use.resource].markedOutput;
}

VkImageLayout PassContext::layout(std::string_view name) const
{
    const ResourceUse& use = declaredUse(*executor_->compiled_, *pass_, name);
    if (!executor_->compiled_->resources[use.resource].isImage)
        throw Error(
            fmt::format("render graph: pass '{}' asks for the layout of '{}', which is a buffer", *passName_, name));
    return use.scope.layout;
}

// ---------------------------------------------------------------------------------------
// GraphExecutor

GraphExecutor::GraphExecutor(gpu::Context& context, ExecutorOptions options)
    : resources_(std::make_unique<DeviceResources>(context, options))
{}

GraphExecutor::~GraphExecutor() = default;

void GraphExecutor::bindImage(std::string_view name, const gpu::Image& image)
{
    resources_->boundImages.insert_or_assign(std::string(name), &image);
}

void GraphExecutor::bindBuffer(std::string_view name, const gpu::Buffer& buffer)
{
    resources_->boundBuffers.insert_or_assign(std::string(name), &buffer);
}

const CompiledGraph& GraphExecutor::prepare(RenderGraph& graph)
{
    DeviceResources& resources = *resources_;
    resources.frameRecorded = false;
    resources.cpuMs.clear();
    resources.timerScope.clear();
    resources.kept.clear();
    const std::shared_ptr<const CompiledGraph> compiled = graph.compile();
    if (compiled != compiled_) {
        compiled_.reset();
        resources.createTransients(*compiled);
        compiled_ = compiled;
    }
    resources.resolveImports(*compiled);
    // Checked before anything is recorded: a missing callback is a declaration error.
    for (const CompiledPass& pass : compiled->passes)
        if (!graph.executeFn(pass.declarationIndex))
            throw Error(fmt::format("render graph: pass '{}' is executed (nothing culled it) but has no execute "
                                    "callback; give it one with PassBuilder::execute()",
                                    pass.name));

    const auto gpuPasses = uint32_t(std::count_if(compiled->passes.begin(), compiled->passes.end(),
                                                  [](const CompiledPass& p) { return p.queue != QueueKind::Host; }));
    resources.timed = resources.options.gpuTimestamps && gpuPasses > 0;
    if (resources.timed && (!resources.timer || resources.timerScopes < gpuPasses)) {
        resources.timer = std::make_unique<gpu::GpuTimer>(resources.context, gpuPasses);
        resources.timerScopes = gpuPasses;
    }
    resources.cpuMs.reserve(compiled->passes.size());
    resources.timerScope.reserve(compiled->passes.size());
    resources.decideRuns(graph, *compiled);
    return *compiled;
}

namespace {

// Runs a pass's callback; an exception becomes an Error naming the pass.
void runCallback(const ExecuteFn& fn, PassContext& context, const CompiledPass& pass, const char* doing)
{
    try {
        fn(context);
    } catch (const std::exception& e) {
        throw Error(fmt::format("render graph: pass '{}' failed while {}: {}", pass.name, doing, e.what()));
    } catch (...) {
        throw Error(fmt::format("render graph: pass '{}' failed while {}: unknown exception", pass.name, doing));
    }
}

} // namespace

void GraphExecutor::recordGpuPass(VkCommandBuffer cmd, RenderGraph& graph, size_t index)
{
    DeviceResources& resources = *resources_;
    const CompiledPass& pass = compiled_->passes[index];
    if (!resources.runs[index]) {
        resources.recordKept(cmd, *compiled_, pass);
        return;
    }
    resources.recordBarriers(cmd, *compiled_, pass.barriersBefore);
    resources.context.beginLabel(cmd, pass.name);
    resources.segmentPasses.push_back(&pass.name);
    const int scope = resources.timed ? int(resources.timer->beginScope(cmd, pass.name)) : -1;
    PassContext context;
    context.cmd_ = cmd;
    context.context_ = &resources.context;
    context.passName_ = &pass.name;
    context.executor_ = this;
    context.pass_ = &pass;
    const auto start = std::chrono::steady_clock::now();
    try {
        runCallback(graph.executeFn(pass.declarationIndex), context, pass, "recording");
    } catch (...) {
        resources.context.endLabel(cmd);
        throw;
    }
    resources.cpuMs.push_back(core::msSince(start));
    resources.timerScope.push_back(scope);
    resources.kept.push_back(0);
    if (scope >= 0) resources.timer->endScope(cmd, uint32_t(scope));
    resources.context.endLabel(cmd);
}

void GraphExecutor::runHostPass(RenderGraph& graph, size_t index)
{
    DeviceResources& resources = *resources_;
    const CompiledPass& pass = compiled_->passes[index];
    PassContext context;
    context.context_ = &resources.context;
    context.passName_ = &pass.name;
    context.executor_ = this;
    context.pass_ = &pass;
    const auto start = std::chrono::steady_clock::now();
    runCallback(graph.executeFn(pass.declarationIndex), context, pass, "running on the host");
    resources.cpuMs.push_back(core::msSince(start));
    resources.timerScope.push_back(-1);
    resources.kept.push_back(0);
}

void GraphExecutor::execute(RenderGraph& graph)
{
    DeviceResources& resources = *resources_;
    const CompiledGraph& compiled = prepare(graph);
    if (!resources.cmd) {
        VkCommandBufferAllocateInfo alloc{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
        alloc.commandPool = resources.context.commandPool();
        alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
        alloc.commandBufferCount = 1;
        gpu::check(vkAllocateCommandBuffers(resources.context.device(), &alloc, &resources.cmd),
                   "vkAllocateCommandBuffers (render graph)");
    }
    resources.beginSegment();
    if (resources.timed) resources.timer->beginFrame(resources.cmd);
    resources.recordBarriers(resources.cmd, compiled, resources.newPersistent);
    try {
        for (size_t i = 0; i < compiled.passes.size(); ++i) {
            const CompiledPass& pass = compiled.passes[i];
            if (pass.queue != QueueKind::Host || !resources.runs[i]) {
                recordGpuPass(resources.cmd, graph, i);
                if (resources.runs[i] && resources.context.isolatePasses() && i + 1 < compiled.passes.size()) {
                    resources.submitSegment();
                    resources.beginSegment();
                }
                continue;
            }
            // The host pass's barriers end the segment before it: their HOST destination
            // makes the segment's writes available to the host, and the wait makes them
            // visible. Its own writes reach the next segment through the submission.
            resources.recordBarriers(resources.cmd, compiled, pass.barriersBefore);
            resources.submitSegment();
            runHostPass(graph, i);
            resources.beginSegment();
        }
        resources.recordBarriers(resources.cmd, compiled, compiled.barriersAfter);
        resources.submitSegment();
    } catch (...) {
        resources.forgetRuns();
        throw;
    }
    resources.rememberRuns();
    resources.frameRecorded = true;
}

void GraphExecutor::record(VkCommandBuffer cmd, RenderGraph& graph)
{
    DeviceResources& resources = *resources_;
    const CompiledGraph& compiled = prepare(graph);
    for (size_t i = 0; i < compiled.passes.size(); ++i)
        if (compiled.passes[i].queue == QueueKind::Host && resources.runs[i])
            throw Error(fmt::format("render graph: pass '{}' is a host pass: record() fills one command buffer and "
                                    "cannot wait for the GPU before it; run the frame with execute()",
                                    compiled.passes[i].name));
    if (resources.timed) resources.timer->beginFrame(cmd);
    resources.recordBarriers(cmd, compiled, resources.newPersistent);
    try {
        for (size_t i = 0; i < compiled.passes.size(); ++i) recordGpuPass(cmd, graph, i);
        resources.recordBarriers(cmd, compiled, compiled.barriersAfter);
    } catch (...) {
        resources.forgetRuns();
        throw;
    }
    resources.rememberRuns();
    resources.frameRecorded = true;
}

std::vector<PassTiming> GraphExecutor::collectTimings() const
{
    const DeviceResources& resources = *resources_;
    if (!resources.frameRecorded)
        throw Error("render graph: collectTimings() needs a frame that execute() finished (or whose record() "
                    "finished and whose command buffer was submitted)");
    std::vector<gpu::ScopeTime> gpuTimes;
    if (resources.timed) gpuTimes = resources.timer->collect();
    std::vector<PassTiming> out;
    out.reserve(resources.cpuMs.size());
    for (size_t i = 0; i < resources.cpuMs.size(); ++i) {
        const int scope = resources.timerScope[i];
        const double gpuMs = scope >= 0 && size_t(scope) < gpuTimes.size() ? gpuTimes[size_t(scope)].gpuMs : 0.0;
        out.push_back({compiled_->passes[i].name, gpuMs, resources.cpuMs[i], resources.kept[i] != 0});
    }
    return out;
}

namespace {

uint32_t lookUp(const std::shared_ptr<const CompiledGraph>& compiled,
                const std::map<std::string, uint32_t, std::less<>>& index, std::string_view name)
{
    if (!compiled) throw Error(fmt::format("render graph: '{}' asked for before any graph was recorded", name));
    const auto found = index.find(name);
    if (found == index.end()) throw Error(fmt::format("render graph: no resource '{}' in the recorded graph", name));
    return found->second;
}

} // namespace

const gpu::Image& GraphExecutor::image(std::string_view name) const
{
    const uint32_t r = lookUp(compiled_, resources_->resourceIndex, name);
    if (!compiled_->resources[r].isImage)
        throw Error(fmt::format("render graph: '{}' is a buffer, not an image", name));
    if (!resources_->images[r])
        throw Error(fmt::format("render graph: image '{}' has no object: no executed pass uses it", name));
    return *resources_->images[r];
}

const gpu::Buffer& GraphExecutor::buffer(std::string_view name) const
{
    const uint32_t r = lookUp(compiled_, resources_->resourceIndex, name);
    if (compiled_->resources[r].isImage) throw Error(fmt::format("render graph: '{}' is an image, not a buffer", name));
    if (!resources_->buffers[r])
        throw Error(fmt::format("render graph: buffer '{}' has no object: no executed pass uses it", name));
    return *resources_->buffers[r];
}

VkImageLayout GraphExecutor::finalLayout(std::string_view name) const
{
    const uint32_t r = lookUp(compiled_, resources_->resourceIndex, name);
    if (!compiled_->resources[r].isImage)
        throw Error(fmt::format("render graph: '{}' is a buffer: it has no layout", name));
    return compiled_->resources[r].finalLayout;
}

VkDeviceSize GraphExecutor::transientBytesAllocated() const { return resources_->bytesAllocated; }

VkDeviceSize GraphExecutor::transientBytesWithoutAliasing() const { return resources_->bytesWithoutAliasing; }

std::vector<TransientMemory> GraphExecutor::transientMemory() const { return resources_->transientMemory; }

std::vector<TransientMemory> GraphExecutor::importedMemory() const
{
    std::vector<TransientMemory> memory;
    if (!compiled_) return memory;
    for (uint32_t r = 0; r < compiled_->resources.size(); ++r) {
        const CompiledResource& res = compiled_->resources[r];
        if (!res.imported || res.firstUse < 0) continue;
        if (res.isImage && r < resources_->images.size() && resources_->images[r])
            memory.push_back({res.name, resources_->images[r]->memorySize()});
        else if (!res.isImage && r < resources_->buffers.size() && resources_->buffers[r])
            memory.push_back({res.name, resources_->buffers[r]->size()});
    }
    return memory;
}

} // namespace penumbra::graph
