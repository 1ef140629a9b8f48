#include "penumbra/graph/GraphExecutor.h"

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

namespace penumbra::graph {

namespace {

VkDeviceSize alignUp(VkDeviceSize value, VkDeviceSize alignment)
{
    return (value + alignment - 1) / alignment * alignment;
}

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

struct GraphExecutor::State {
    State(gpu::Context& context, ExecutorOptions options) : context(context), options(options) {}
    ~State() { releaseTransients(); }
    State(const State&) = delete;
    State& operator=(const State&) = delete;

    gpu::Context& context;
    ExecutorOptions options;
    std::map<std::string, const gpu::Image*, std::less<>> boundImages;
    std::map<std::string, const gpu::Buffer*, std::less<>> boundBuffers;

    // Per compiled graph, indexed like CompiledGraph::resources (empty objects for
    // imported and unused resources).
    std::vector<gpu::Image> transientImages;
    std::vector<gpu::Buffer> transientBuffers;
    std::vector<VkDeviceMemory> memory;
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
    std::vector<double> cpuMs;  // per executed pass of the last frame
    bool frameRecorded = false;

    // Reused between frames so that recording barriers allocates nothing.
    std::vector<VkImageMemoryBarrier2> imageBarriers;
    std::vector<VkBufferMemoryBarrier2> bufferBarriers;

    void createTransients(const CompiledGraph& graph);
    void placeSlot(const CompiledGraph& graph, uint32_t slot, const std::vector<VkMemoryRequirements>& requirements);
    VkDeviceMemory allocate(VkDeviceSize size, uint32_t typeBits, const std::string& name);
    void bind(const CompiledGraph& graph, uint32_t r, VkDeviceMemory memory);
    void releaseTransients();
    void resolveImports(const CompiledGraph& graph);
    void recordBarriers(VkCommandBuffer cmd, const CompiledGraph& graph, const std::vector<Barrier>& barriers);
};

void GraphExecutor::State::releaseTransients()
{
    // Objects before the memory they are bound to.
    transientImages.clear();
    transientBuffers.clear();
    for (VkDeviceMemory block : memory) vkFreeMemory(context.device(), block, nullptr);
    memory.clear();
    bytesAllocated = 0;
    bytesWithoutAliasing = 0;
    transientMemory.clear();
}

void GraphExecutor::State::createTransients(const CompiledGraph& graph)
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
    resourceIndex.clear();

    std::vector<VkMemoryRequirements> requirements(count);
    for (uint32_t r = 0; r < count; ++r) {
        const CompiledResource& res = graph.resources[r];
        resourceIndex.emplace(res.name, r);
        if (res.imported || res.firstUse < 0) continue;
        try {
            if (res.isImage) {
                transientImages[r] = gpu::Image::createUnbound(
                    context, {res.width, res.height, res.format, res.imageUsage, res.name});
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
    // compile() puts every used transient in a slot; should one be missing, it still
    // gets memory rather than an unbound object.
    for (uint32_t r = 0; r < count; ++r) {
        const CompiledResource& res = graph.resources[r];
        if (res.imported || res.firstUse < 0 || res.memorySlot >= 0) continue;
        bind(graph, r, allocate(requirements[r].size, requirements[r].memoryTypeBits, res.name));
    }
}

// One allocation for the slot's members, sized from the real requirements: the largest
// member, rounded to the largest alignment (all are bound at offset 0, where every
// alignment holds). The compiler's slot sizes are estimates and are not used here.
void GraphExecutor::State::placeSlot(const CompiledGraph& graph, uint32_t slot,
                                     const std::vector<VkMemoryRequirements>& requirements)
{
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
            bind(graph, r, allocate(req.size, req.memoryTypeBits, graph.resources[r].name));
            continue;
        }
        typeBits &= req.memoryTypeBits;
        size = std::max(size, req.size);
        alignment = std::max(alignment, req.alignment);
        shared.push_back(r);
        names += fmt::format("{}{}", names.empty() ? "" : ", ", graph.resources[r].name);
    }
    if (shared.empty()) return;
    const VkDeviceMemory block = allocate(alignUp(size, alignment), typeBits,
                                          fmt::format("render graph slot {}: {}", slot, names));
    for (uint32_t r : shared) bind(graph, r, block);
}

VkDeviceMemory GraphExecutor::State::allocate(VkDeviceSize size, uint32_t typeBits, const std::string& name)
{
    VkMemoryAllocateInfo info{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
    info.allocationSize = size;
    info.memoryTypeIndex = context.findMemoryType(typeBits, 0, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    VkDeviceMemory block = VK_NULL_HANDLE;
    gpu::check(vkAllocateMemory(context.device(), &info, nullptr, &block),
               fmt::format("vkAllocateMemory ({} bytes for {})", size, name));
    memory.push_back(block);
    bytesAllocated += size;
    context.setName(VK_OBJECT_TYPE_DEVICE_MEMORY, reinterpret_cast<uint64_t>(block), name);
    return block;
}

void GraphExecutor::State::bind(const CompiledGraph& graph, uint32_t r, VkDeviceMemory block)
{
    const CompiledResource& res = graph.resources[r];
    try {
        if (res.isImage) transientImages[r].bindMemory(block, 0);
        else transientBuffers[r].bindMemory(block, 0);
    } catch (const Error& e) {
        throw GpuError(fmt::format("render graph: transient {} '{}': {}", kindName(res), res.name, e.what()));
    }
}

void GraphExecutor::State::resolveImports(const CompiledGraph& graph)
{
    for (uint32_t r = 0; r < graph.resources.size(); ++r) {
        const CompiledResource& res = graph.resources[r];
        if (!res.imported || res.firstUse < 0) continue;
        const auto missing = [&] {
            return Error(fmt::format("render graph: imported {} '{}' is not bound (used by {}); call "
                                     "GraphExecutor::bind{}() before record()",
                                     kindName(res), res.name, passesUsing(graph, r), res.isImage ? "Image" : "Buffer"));
        };
        if (res.isImage) {
            const auto found = boundImages.find(res.name);
            if (found == boundImages.end()) throw missing();
            const gpu::ImageDesc& desc = found->second->desc();
            if (desc.width != res.width || desc.height != res.height || desc.format != res.format)
                throw Error(fmt::format("render graph: imported image '{}' is declared {}x{} {} but the bound image "
                                        "'{}' is {}x{} {}",
                                        res.name, res.width, res.height, vk::to_string(vk::Format(res.format)),
                                        desc.name, desc.width, desc.height, vk::to_string(vk::Format(desc.format))));
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
            buffers[r] = found->second;
        }
    }
}

void GraphExecutor::State::recordBarriers(VkCommandBuffer cmd, const CompiledGraph& graph,
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
            out.subresourceRange = {barrierAspect(graph.resources[b.resource].format), 0, 1, 0, 1};
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

// ---------------------------------------------------------------------------------------
// PassContext

const gpu::Image& PassContext::image(std::string_view name) const
{
    const ResourceUse& use = declaredUse(*executor_->compiled_, *pass_, name);
    const gpu::Image* object = executor_->state_->images[use.resource];
    if (!object)
        throw Error(fmt::format("render graph: pass '{}' asks for image '{}', which is a buffer", *passName_, name));
    return *object;
}

const gpu::Buffer& PassContext::buffer(std::string_view name) const
{
    const ResourceUse& use = declaredUse(*executor_->compiled_, *pass_, name);
    const gpu::Buffer* object = executor_->state_->buffers[use.resource];
    if (!object)
        throw Error(fmt::format("render graph: pass '{}' asks for buffer '{}', which is an image", *passName_, name));
    return *object;
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
    : state_(std::make_unique<State>(context, options))
{}

GraphExecutor::~GraphExecutor() = default;

void GraphExecutor::bindImage(std::string_view name, const gpu::Image& image)
{
    state_->boundImages.insert_or_assign(std::string(name), &image);
}

void GraphExecutor::bindBuffer(std::string_view name, const gpu::Buffer& buffer)
{
    state_->boundBuffers.insert_or_assign(std::string(name), &buffer);
}

void GraphExecutor::record(VkCommandBuffer cmd, RenderGraph& graph)
{
    State& st = *state_;
    st.frameRecorded = false;
    st.cpuMs.clear();
    const std::shared_ptr<const CompiledGraph> compiled = graph.compile();
    if (compiled != compiled_) {
        compiled_.reset();
        st.createTransients(*compiled);
        compiled_ = compiled;
    }
    st.resolveImports(*compiled);
    // Checked before anything is recorded: a missing callback is a declaration error.
    for (const CompiledPass& pass : compiled->passes)
        if (!graph.executeFn(pass.declarationIndex))
            throw Error(fmt::format("render graph: pass '{}' is executed (nothing culled it) but has no execute "
                                    "callback; give it one with PassBuilder::execute()",
                                    pass.name));

    const auto passCount = uint32_t(compiled->passes.size());
    const bool timed = st.options.gpuTimestamps && passCount > 0;
    if (timed) {
        if (!st.timer || st.timerScopes < passCount) {
            st.timer = std::make_unique<gpu::GpuTimer>(st.context, passCount);
            st.timerScopes = passCount;
        }
        st.timer->beginFrame(cmd);
    }
    st.cpuMs.reserve(passCount);
    for (const CompiledPass& pass : compiled->passes) {
        st.recordBarriers(cmd, *compiled, pass.barriersBefore);
        st.context.beginLabel(cmd, pass.name);
        const uint32_t scope = timed ? st.timer->beginScope(cmd, pass.name) : 0;
        PassContext context;
        context.cmd_ = cmd;
        context.context_ = &st.context;
        context.passName_ = &pass.name;
        context.executor_ = this;
        context.pass_ = &pass;
        const auto start = std::chrono::steady_clock::now();
        try {
            graph.executeFn(pass.declarationIndex)(context);
        } catch (const std::exception& e) {
            st.context.endLabel(cmd);
            throw Error(fmt::format("render graph: pass '{}' failed while recording: {}", pass.name, e.what()));
        } catch (...) {
            st.context.endLabel(cmd);
            throw Error(fmt::format("render graph: pass '{}' failed while recording: unknown exception", pass.name));
        }
        st.cpuMs.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
        if (timed) st.timer->endScope(cmd, scope);
        st.context.endLabel(cmd);
    }
    st.recordBarriers(cmd, *compiled, compiled->barriersAfter);
    st.frameRecorded = true;
}

std::vector<PassTiming> GraphExecutor::collectTimings() const
{
    const State& st = *state_;
    if (!st.frameRecorded)
        throw Error("render graph: collectTimings() needs a frame whose record() finished and whose command buffer "
                    "was submitted");
    std::vector<gpu::ScopeTime> gpuTimes;
    if (st.options.gpuTimestamps && !st.cpuMs.empty()) gpuTimes = st.timer->collect();
    std::vector<PassTiming> out;
    out.reserve(st.cpuMs.size());
    for (size_t i = 0; i < st.cpuMs.size(); ++i)
        out.push_back({compiled_->passes[i].name, i < gpuTimes.size() ? gpuTimes[i].gpuMs : 0.0, st.cpuMs[i]});
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
    const uint32_t r = lookUp(compiled_, state_->resourceIndex, name);
    if (!compiled_->resources[r].isImage)
        throw Error(fmt::format("render graph: '{}' is a buffer, not an image", name));
    if (!state_->images[r])
        throw Error(fmt::format("render graph: image '{}' has no object: no executed pass uses it", name));
    return *state_->images[r];
}

const gpu::Buffer& GraphExecutor::buffer(std::string_view name) const
{
    const uint32_t r = lookUp(compiled_, state_->resourceIndex, name);
    if (compiled_->resources[r].isImage) throw Error(fmt::format("render graph: '{}' is an image, not a buffer", name));
    if (!state_->buffers[r])
        throw Error(fmt::format("render graph: buffer '{}' has no object: no executed pass uses it", name));
    return *state_->buffers[r];
}

VkImageLayout GraphExecutor::finalLayout(std::string_view name) const
{
    const uint32_t r = lookUp(compiled_, state_->resourceIndex, name);
    if (!compiled_->resources[r].isImage)
        throw Error(fmt::format("render graph: '{}' is a buffer: it has no layout", name));
    return compiled_->resources[r].finalLayout;
}

VkDeviceSize GraphExecutor::transientBytesAllocated() const { return state_->bytesAllocated; }

VkDeviceSize GraphExecutor::transientBytesWithoutAliasing() const { return state_->bytesWithoutAliasing; }

std::vector<TransientMemory> GraphExecutor::transientMemory() const { return state_->transientMemory; }

} // namespace penumbra::graph
