#include "penumbra/graph/RenderGraph.h"

#include "graph/Align.h"
#include "penumbra/core/Error.h"

#include <fmt/format.h>
#include <vulkan/vulkan.hpp>
#include <vulkan/vulkan_format_traits.hpp>
#include <vulkan/vulkan_to_string.hpp>

#include <algorithm>
#include <limits>
#include <optional>
#include <queue>
#include <unordered_map>

namespace penumbra::graph {

namespace {

// Placement estimates: drivers commonly align images to 64 KiB pages and buffers to far
// less; the real figures come from vkGet*MemoryRequirements once the graph executes.
constexpr VkDeviceSize kImageAlignment = 64 * 1024;
constexpr VkDeviceSize kBufferAlignment = 256;

constexpr VkAccessFlags2 kWriteAccess =
    VK_ACCESS_2_SHADER_WRITE_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT | VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT |
    VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT | VK_ACCESS_2_HOST_WRITE_BIT |
    VK_ACCESS_2_MEMORY_WRITE_BIT;

const char* usageName(Usage usage)
{
    switch (usage) {
    case Usage::ColorAttachment: return "colour attachment";
    case Usage::DepthAttachment: return "depth attachment";
    case Usage::Sampled: return "sampled";
    case Usage::Storage: return "storage";
    case Usage::TransferSrc: return "transfer source";
    case Usage::TransferDst: return "transfer destination";
    case Usage::UniformBuffer: return "uniform buffer";
    case Usage::VertexBuffer: return "vertex buffer";
    case Usage::IndexBuffer: return "index buffer";
    case Usage::IndirectBuffer: return "indirect buffer";
    case Usage::HostRead: return "host read";
    case Usage::HostWrite: return "host write";
    }
    return "?";
}

bool isDepthFormat(VkFormat format)
{
    switch (format) {
    case VK_FORMAT_D16_UNORM:
    case VK_FORMAT_X8_D24_UNORM_PACK32:
    case VK_FORMAT_D32_SFLOAT:
    case VK_FORMAT_D16_UNORM_S8_UINT:
    case VK_FORMAT_D24_UNORM_S8_UINT:
    case VK_FORMAT_D32_SFLOAT_S8_UINT: return true;
    default: return false;
    }
}

VkDeviceSize imageBytes(const ImageDesc& desc)
{
    const auto format = static_cast<vk::Format>(desc.format);
    const auto extent = vk::blockExtent(format);
    const VkDeviceSize blockBytes = vk::blockSize(format);
    if (blockBytes == 0) throw Error(fmt::format("render graph: image '{}': format {} has no known size", desc.name, int(desc.format)));
    const VkDeviceSize blocksX = (desc.width + extent[0] - 1) / extent[0];
    const VkDeviceSize blocksY = (desc.height + extent[1] - 1) / extent[1];
    return blocksX * blocksY * blockBytes * desc.layers;
}

struct ResourceState {
    VkImageLayout layout = VK_IMAGE_LAYOUT_UNDEFINED;
    VkPipelineStageFlags2 writeStage = VK_PIPELINE_STAGE_2_NONE;
    VkAccessFlags2 writeAccess = VK_ACCESS_2_NONE;
    VkPipelineStageFlags2 readStages = VK_PIPELINE_STAGE_2_NONE;  // since the last write
    std::vector<AccessScope> visibleTo;                            // scopes the last write reached
    bool touched = false;
};

} // namespace

AccessScope deriveScope(Usage usage, Access direction, QueueKind queue, bool isImage, bool depthFormat)
{
    const bool write = direction == Access::Write;
    auto require = [&](bool ok, const char* what) {
        if (!ok) throw Error(fmt::format("{} usage {}", usageName(usage), what));
    };
    const bool imageOnly = usage == Usage::ColorAttachment || usage == Usage::DepthAttachment || usage == Usage::Sampled;
    const bool hostUsage = usage == Usage::HostRead || usage == Usage::HostWrite;
    const bool bufferOnly = usage == Usage::UniformBuffer || usage == Usage::VertexBuffer ||
                            usage == Usage::IndexBuffer || usage == Usage::IndirectBuffer || hostUsage;
    require(!imageOnly || isImage, "needs an image, not a buffer");
    require(!bufferOnly || !isImage, "needs a buffer, not an image");
    const bool transferUsage = usage == Usage::TransferSrc || usage == Usage::TransferDst;
    require(queue != QueueKind::Transfer || transferUsage, "is not available on a transfer pass");
    // The CPU can only reach mapped buffers: a host pass declares nothing else, and the
    // host usages mean nothing to a pass that records commands.
    require(queue != QueueKind::Host || hostUsage,
            "is not available on a host pass (it reads and writes buffers, as host read / host write)");
    require(!hostUsage || queue == QueueKind::Host, "needs a host pass");

    // Graphics passes may read in either shader stage; naming both keeps a vertex
    // shader's reads synchronised at the cost of a slightly earlier wait.
    const VkPipelineStageFlags2 shaderStage =
        queue == QueueKind::Compute ? VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT
                                    : VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT | VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT;
    constexpr VkPipelineStageFlags2 fragmentTests =
        VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT;
    const VkImageLayout noLayout = VK_IMAGE_LAYOUT_UNDEFINED;

    switch (usage) {
    case Usage::ColorAttachment:
        require(write, "is write-only");
        require(queue == QueueKind::Graphics, "needs a graphics pass");
        return {VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT};
    case Usage::DepthAttachment:
        require(queue == QueueKind::Graphics, "needs a graphics pass");
        if (write)
            return {VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, fragmentTests,
                    VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT};
        return {VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL, fragmentTests, VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT};
    case Usage::Sampled:
        require(!write, "is read-only");
        return {depthFormat ? VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL : VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL,
                shaderStage, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT};
    case Usage::Storage:
        return {isImage ? VK_IMAGE_LAYOUT_GENERAL : noLayout, shaderStage,
                write ? VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT : VK_ACCESS_2_SHADER_STORAGE_READ_BIT};
    case Usage::TransferSrc:
        require(!write, "is read-only");
        return {isImage ? VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL : noLayout, VK_PIPELINE_STAGE_2_TRANSFER_BIT,
                VK_ACCESS_2_TRANSFER_READ_BIT};
    case Usage::TransferDst:
        require(write, "is write-only");
        return {isImage ? VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL : noLayout, VK_PIPELINE_STAGE_2_TRANSFER_BIT,
                VK_ACCESS_2_TRANSFER_WRITE_BIT};
    case Usage::UniformBuffer:
        require(!write, "is read-only");
        return {noLayout, shaderStage, VK_ACCESS_2_UNIFORM_READ_BIT};
    case Usage::VertexBuffer:
        require(!write, "is read-only");
        require(queue == QueueKind::Graphics, "needs a graphics pass");
        return {noLayout, VK_PIPELINE_STAGE_2_VERTEX_ATTRIBUTE_INPUT_BIT, VK_ACCESS_2_VERTEX_ATTRIBUTE_READ_BIT};
    case Usage::IndexBuffer:
        require(!write, "is read-only");
        require(queue == QueueKind::Graphics, "needs a graphics pass");
        return {noLayout, VK_PIPELINE_STAGE_2_INDEX_INPUT_BIT, VK_ACCESS_2_INDEX_READ_BIT};
    case Usage::IndirectBuffer:
        require(!write, "is read-only");
        return {noLayout, VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT, VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT};
    // The HOST stage in a barrier makes device writes available to the host before the
    // executor's wait (read), and orders the device after the host's writes (write).
    case Usage::HostRead:
        require(!write, "is read-only");
        return {noLayout, VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT};
    case Usage::HostWrite:
        require(write, "is write-only");
        return {noLayout, VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_WRITE_BIT};
    }
    throw Error("unknown usage");
}

// ---------------------------------------------------------------------------------------
// Declaration

PassBuilder& PassBuilder::read(std::string_view resource, Usage usage)
{
    graph_->addAccess(pass_, resource, usage, Access::Read);
    return *this;
}

PassBuilder& PassBuilder::write(std::string_view resource, Usage usage)
{
    graph_->addAccess(pass_, resource, usage, Access::Write);
    return *this;
}

bool RenderGraph::isWritten(std::string_view resource) const
{
    return std::any_of(passes_.begin(), passes_.end(), [&](const PassDecl& pass) {
        return std::any_of(pass.accesses.begin(), pass.accesses.end(), [&](const AccessDecl& a) {
            return a.direction == Access::Write && a.resource == resource;
        });
    });
}

std::vector<std::string> RenderGraph::writtenImages() const
{
    std::vector<std::string> names;
    for (const ResourceDecl& r : resources_) {
        if (r.isImage && isWritten(r.image.name)) names.push_back(r.image.name);
    }
    return names;
}

PassBuilder& PassBuilder::execute(ExecuteFn fn)
{
    graph_->passes_[pass_].execute = std::move(fn);
    return *this;
}

PassBuilder& PassBuilder::dependsOn(std::string_view state)
{
    if (state.empty()) throw Error(fmt::format("render graph: pass '{}' depends on a state without a name", graph_->passes_[pass_].name));
    std::vector<std::string>& states = graph_->passes_[pass_].states;
    if (std::find(states.begin(), states.end(), state) == states.end()) {
        states.emplace_back(state);
        ++graph_->version_;
    }
    return *this;
}

void RenderGraph::setKeepUnchanged(bool keep)
{
    if (keep == keepUnchanged_) return;
    keepUnchanged_ = keep;
    ++version_;
}

void RenderGraph::setState(std::string_view state, uint64_t version) { states_.insert_or_assign(std::string(state), version); }

std::optional<uint64_t> RenderGraph::stateVersion(std::string_view state) const
{
    const auto found = states_.find(std::string(state));
    if (found == states_.end()) return std::nullopt;
    return found->second;
}

RenderGraph::ResourceDecl* RenderGraph::findResource(std::string_view name)
{
    const auto found = resourceIndex_.find(std::string(name));
    return found == resourceIndex_.end() ? nullptr : &resources_[found->second];
}

void RenderGraph::declare(ResourceDecl decl, const std::string& name)
{
    if (name.empty()) throw Error("render graph: a resource needs a name");
    if (const ResourceDecl* existing = findResource(name)) {
        if (existing->isImage != decl.isImage)
            throw Error(fmt::format("render graph: '{}' is declared both as an image and as a buffer", name));
        if (existing->isImage && !(existing->image == decl.image)) {
            const ImageDesc& a = existing->image;
            const ImageDesc& b = decl.image;
            throw Error(fmt::format("render graph: image '{}' declared twice with different descriptions: "
                                    "{}x{}x{} format {}{} vs {}x{}x{} format {}{}",
                                    name, a.width, a.height, a.layers, int(a.format), a.imported ? " imported" : "",
                                    b.width, b.height, b.layers, int(b.format), b.imported ? " imported" : ""));
        }
        if (!existing->isImage && !(existing->buffer == decl.buffer))
            throw Error(fmt::format("render graph: buffer '{}' declared twice with different descriptions: "
                                    "{} bytes{} vs {} bytes{}",
                                    name, existing->buffer.size, existing->buffer.imported ? " imported" : "",
                                    decl.buffer.size, decl.buffer.imported ? " imported" : ""));
        return;
    }
    resourceIndex_.emplace(name, uint32_t(resources_.size()));
    resources_.push_back(std::move(decl));
    ++version_;
}

void RenderGraph::declareImage(const ImageDesc& desc)
{
    if (desc.width == 0 || desc.height == 0)
        throw Error(fmt::format("render graph: image '{}': width and height must be > 0", desc.name));
    if (desc.layers == 0) throw Error(fmt::format("render graph: image '{}': layers must be > 0", desc.name));
    ResourceDecl decl;
    decl.image = desc;
    declare(std::move(decl), desc.name);
}

void RenderGraph::declareBuffer(const BufferDesc& desc)
{
    if (desc.size == 0) throw Error(fmt::format("render graph: buffer '{}': size must be > 0", desc.name));
    ResourceDecl decl;
    decl.isImage = false;
    decl.buffer = desc;
    declare(std::move(decl), desc.name);
}

PassBuilder RenderGraph::addPass(std::string name, QueueKind queue, bool sideEffect)
{
    if (name.empty()) throw Error("render graph: a pass needs a name");
    if (!passNames_.insert(name).second) throw Error(fmt::format("render graph: pass '{}' is added twice", name));
    passes_.push_back(PassDecl{std::move(name), queue, sideEffect, {}});
    ++version_;
    return PassBuilder(*this, uint32_t(passes_.size() - 1));
}

void RenderGraph::addAccess(uint32_t pass, std::string_view resource, Usage usage, Access direction)
{
    passes_[pass].accesses.push_back(AccessDecl{std::string(resource), usage, direction});
    ++version_;
}

void RenderGraph::markOutput(std::string_view resource)
{
    ResourceDecl* decl = findResource(resource);
    if (!decl) throw Error(fmt::format("render graph: markOutput('{}'): no such resource is declared", resource));
    if (!decl->markedOutput) {
        decl->markedOutput = true;
        ++version_;
    }
}

void RenderGraph::readBack(std::string_view buffer)
{
    ResourceDecl* decl = findResource(buffer);
    if (!decl) throw Error(fmt::format("render graph: readBack('{}'): no such resource is declared", buffer));
    if (decl->isImage || !decl->buffer.imported)
        throw Error(fmt::format("render graph: readBack('{}'): only an imported buffer can be read back (bound to "
                                "a host-visible buffer of its owner's); '{}' is {}",
                                buffer, buffer, decl->isImage ? "an image" : "a transient buffer"));
    if (!decl->readBack) {
        decl->readBack = true;
        ++version_;
    }
}

// ---------------------------------------------------------------------------------------
// Compilation

class GraphCompiler {
public:
    GraphCompiler(const std::vector<RenderGraph::ResourceDecl>& resources,
                  const std::vector<RenderGraph::PassDecl>& passes, bool keepUnchanged)
        : resources_(resources), passes_(passes), keepUnchanged_(keepUnchanged), uses_(passes.size()),
          preds_(passes.size()), succs_(passes.size())
    {}

    std::shared_ptr<const CompiledGraph> run()
    {
        resolveUses();
        buildDependencies();
        const std::vector<uint32_t> order = topologicalOrder();
        checkWritersOrdered(order);
        const std::vector<bool> live = findLivePasses();

        auto out = std::make_shared<CompiledGraph>();
        for (uint32_t p = 0; p < passes_.size(); ++p)
            if (!live[p])
                out->culled.push_back({passes_[p].name, "no marked output or side effect reads its outputs"});
        for (uint32_t p : order)
            if (live[p]) out->passes.push_back({passes_[p].name, passes_[p].queue, p, uses_[p], {}});

        describeResources(*out);
        findKeptPasses(*out);
        collectUsageFlags(*out, live);
        computeLifetimes(*out);
        assignMemorySlots(*out);
        verifyAliasing(*out);
        deriveBarriers(*out);
        return out;
    }

private:
    const RenderGraph::ResourceDecl& decl(uint32_t r) const { return resources_[r]; }
    const std::string& resourceName(uint32_t r) const
    {
        return resources_[r].isImage ? resources_[r].image.name : resources_[r].buffer.name;
    }
    bool imported(uint32_t r) const
    {
        return resources_[r].isImage ? resources_[r].image.imported : resources_[r].buffer.imported;
    }

    void resolveUses()
    {
        std::unordered_map<std::string_view, uint32_t> index;
        for (uint32_t r = 0; r < resources_.size(); ++r) index.emplace(resourceName(r), r);

        for (uint32_t p = 0; p < passes_.size(); ++p) {
            const auto& pass = passes_[p];
            for (const auto& access : pass.accesses) {
                const auto found = index.find(access.resource);
                if (found == index.end())
                    throw Error(fmt::format("render graph: pass '{}' {} '{}', which is not declared", pass.name,
                                            access.direction == Access::Read ? "reads" : "writes",
                                            access.resource));
                const uint32_t r = found->second;
                const bool image = decl(r).isImage;
                AccessScope scope;
                try {
                    scope = deriveScope(access.usage, access.direction, pass.queue, image,
                                        image && isDepthFormat(decl(r).image.format));
                } catch (const Error& e) {
                    throw Error(fmt::format("render graph: pass '{}', resource '{}': {}", pass.name,
                                            access.resource, e.what()));
                }
                mergeUse(p, r, scope, access.direction);
                resolved_.push_back({p, r, access.usage});
            }
        }
    }

    void mergeUse(uint32_t p, uint32_t r, const AccessScope& scope, Access direction)
    {
        auto& list = uses_[p];
        auto it = std::find_if(list.begin(), list.end(), [&](const ResourceUse& u) { return u.resource == r; });
        if (it == list.end()) {
            list.push_back({r, false, false, scope});
            it = list.end() - 1;
        } else if (it->scope.layout != scope.layout) {
            throw Error(fmt::format("render graph: pass '{}' uses image '{}' in two layouts ({} and {}); "
                                    "split the pass or use one usage",
                                    passes_[p].name, resourceName(r), vk::to_string(vk::ImageLayout(it->scope.layout)),
                                    vk::to_string(vk::ImageLayout(scope.layout))));
        } else {
            it->scope.stage |= scope.stage;
            it->scope.access |= scope.access;
        }
        (direction == Access::Read ? it->reads : it->writes) = true;
    }

    // Pure writers come before passes that read-modify-write the resource, and every
    // writer comes before the passes that only read it: readers see the final contents.
    void buildDependencies()
    {
        std::vector<std::vector<uint32_t>> pureWriters(resources_.size()), modifiers(resources_.size()),
            pureReaders(resources_.size());
        writers_.assign(resources_.size(), {});
        for (uint32_t p = 0; p < passes_.size(); ++p)
            for (const ResourceUse& use : uses_[p]) {
                if (use.writes) writers_[use.resource].push_back(p);
                if (use.writes && use.reads) modifiers[use.resource].push_back(p);
                else if (use.writes) pureWriters[use.resource].push_back(p);
                else pureReaders[use.resource].push_back(p);
            }
        for (uint32_t r = 0; r < resources_.size(); ++r) {
            // A read-modify-write needs earlier contents too: only pure writers initialise.
            if (pureWriters[r].empty() && !imported(r)) {
                if (!modifiers[r].empty())
                    throw Error(fmt::format("render graph: pass '{}' reads and writes '{}', but no pass writes it "
                                            "first and it is not imported; add a pass that initialises it or "
                                            "declare it imported",
                                            passes_[modifiers[r].front()].name, resourceName(r)));
                if (!pureReaders[r].empty())
                    throw Error(fmt::format("render graph: pass '{}' reads '{}', which no pass writes and which "
                                            "is not imported; write it first or declare it imported",
                                            passes_[pureReaders[r].front()].name, resourceName(r)));
            }
            for (uint32_t w : pureWriters[r]) {
                for (uint32_t m : modifiers[r]) addEdge(w, m);
                for (uint32_t reader : pureReaders[r]) addEdge(w, reader);
            }
            for (uint32_t m : modifiers[r])
                for (uint32_t reader : pureReaders[r]) addEdge(m, reader);
        }
        for (auto& list : preds_) {
            std::sort(list.begin(), list.end());
            list.erase(std::unique(list.begin(), list.end()), list.end());
        }
        for (auto& list : succs_) {
            std::sort(list.begin(), list.end());
            list.erase(std::unique(list.begin(), list.end()), list.end());
        }
    }

    void addEdge(uint32_t from, uint32_t to)
    {
        if (from == to) return;
        succs_[from].push_back(to);
        preds_[to].push_back(from);
    }

    // Kahn's algorithm taking the lowest declaration index first: the result is the
    // declaration order wherever the dependencies allow it.
    std::vector<uint32_t> topologicalOrder() const
    {
        std::vector<uint32_t> inDegree(passes_.size());
        for (uint32_t p = 0; p < passes_.size(); ++p) inDegree[p] = uint32_t(preds_[p].size());
        std::priority_queue<uint32_t, std::vector<uint32_t>, std::greater<>> ready;
        for (uint32_t p = 0; p < passes_.size(); ++p)
            if (inDegree[p] == 0) ready.push(p);
        std::vector<uint32_t> order;
        order.reserve(passes_.size());
        while (!ready.empty()) {
            const uint32_t p = ready.top();
            ready.pop();
            order.push_back(p);
            for (uint32_t s : succs_[p])
                if (--inDegree[s] == 0) ready.push(s);
        }
        if (order.size() != passes_.size()) throwCycle(inDegree);
        return order;
    }

    // Every pass left with in-degree > 0 lies on or after a cycle; walking predecessors
    // that are also left must repeat a pass, and the walk between repeats is a cycle.
    [[noreturn]] void throwCycle(const std::vector<uint32_t>& inDegree) const
    {
        uint32_t p = 0;
        while (inDegree[p] == 0) ++p;
        std::vector<int> seenAt(passes_.size(), -1);
        std::vector<uint32_t> walk;
        while (seenAt[p] < 0) {
            seenAt[p] = int(walk.size());
            walk.push_back(p);
            p = *std::find_if(preds_[p].begin(), preds_[p].end(), [&](uint32_t q) { return inDegree[q] > 0; });
        }
        // The walk follows predecessors, so reverse it to read in execution direction.
        std::vector<uint32_t> cycle(walk.begin() + seenAt[p], walk.end());
        std::reverse(cycle.begin(), cycle.end());
        std::rotate(cycle.begin(), std::min_element(cycle.begin(), cycle.end()), cycle.end());
        std::string text;
        for (uint32_t q : cycle) text += fmt::format("'{}' -> ", passes_[q].name);
        text += fmt::format("'{}'", passes_[cycle.front()].name);
        throw Error(fmt::format("render graph: dependency cycle: {}", text));
    }

    // Two writers of one resource must be ordered by some chain of dependencies, or
    // which contents the readers see would depend on the scheduler's whim.
    void checkWritersOrdered(const std::vector<uint32_t>& order) const
    {
        const size_t words = (passes_.size() + 63) / 64;
        std::vector<uint64_t> ancestors(passes_.size() * words, 0);
        auto row = [&](uint32_t p) { return ancestors.data() + size_t(p) * words; };
        for (uint32_t p : order)
            for (uint32_t q : preds_[p]) {
                uint64_t* dst = row(p);
                const uint64_t* src = row(q);
                for (size_t w = 0; w < words; ++w) dst[w] |= src[w];
                dst[q / 64] |= uint64_t(1) << (q % 64);
            }
        auto reaches = [&](uint32_t from, uint32_t to) { return (row(to)[from / 64] >> (from % 64)) & 1; };
        for (uint32_t r = 0; r < resources_.size(); ++r) {
            const auto& writers = writers_[r];
            for (size_t i = 0; i < writers.size(); ++i)
                for (size_t j = i + 1; j < writers.size(); ++j)
                    if (!reaches(writers[i], writers[j]) && !reaches(writers[j], writers[i]))
                        throw Error(fmt::format("render graph: passes '{}' and '{}' both write '{}' with no order "
                                                "between them; make one depend on the other",
                                                passes_[writers[i]].name, passes_[writers[j]].name,
                                                resourceName(r)));
        }
    }

    // Live: side-effect passes, writers of marked outputs, and everything they depend on.
    std::vector<bool> findLivePasses() const
    {
        std::vector<bool> live(passes_.size(), false);
        std::vector<uint32_t> stack;
        for (uint32_t p = 0; p < passes_.size(); ++p) {
            bool root = passes_[p].sideEffect;
            for (const ResourceUse& use : uses_[p])
                root = root || (use.writes && (decl(use.resource).markedOutput || decl(use.resource).readBack));
            if (root) {
                live[p] = true;
                stack.push_back(p);
            }
        }
        while (!stack.empty()) {
            const uint32_t p = stack.back();
            stack.pop_back();
            for (uint32_t q : preds_[p])
                if (!live[q]) {
                    live[q] = true;
                    stack.push_back(q);
                }
        }
        return live;
    }

    // The passes that may be kept: those that declared states, less those that write a
    // resource some pass running every frame also writes (its writes would be lost, or
    // mixed with a kept result), repeated until no more drop out. What they write is
    // persistent.
    void findKeptPasses(CompiledGraph& out) const
    {
        if (!keepUnchanged_) return;
        for (CompiledPass& pass : out.passes) pass.keptWhile = passes_[pass.declarationIndex].states;
        for (bool dropped = true; dropped;) {
            dropped = false;
            std::vector<bool> everyFrame(out.resources.size(), false);
            for (const CompiledPass& pass : out.passes)
                for (const ResourceUse& use : pass.uses)
                    if (use.writes && pass.keptWhile.empty()) everyFrame[use.resource] = true;
            for (CompiledPass& pass : out.passes) {
                if (pass.keptWhile.empty()) continue;
                const bool shared = std::any_of(pass.uses.begin(), pass.uses.end(), [&](const ResourceUse& use) {
                    return use.writes && everyFrame[use.resource];
                });
                if (shared) {
                    pass.keptWhile.clear();
                    dropped = true;
                }
            }
        }
        for (const CompiledPass& pass : out.passes)
            if (!pass.keptWhile.empty())
                for (const ResourceUse& use : pass.uses)
                    if (use.writes && !out.resources[use.resource].imported) out.resources[use.resource].persistent = true;
    }

    void describeResources(CompiledGraph& out) const
    {
        out.resources.resize(resources_.size());
        for (uint32_t r = 0; r < resources_.size(); ++r) {
            CompiledResource& res = out.resources[r];
            const auto& d = decl(r);
            res.name = resourceName(r);
            res.isImage = d.isImage;
            res.imported = imported(r);
            res.markedOutput = d.markedOutput;
            res.readBack = d.readBack;
            res.hostVisible = d.readBack;
            if (d.isImage) {
                res.width = d.image.width;
                res.height = d.image.height;
                res.layers = d.image.layers;
                res.format = d.image.format;
                res.sizeBytes = imageBytes(d.image);
            } else {
                res.sizeBytes = d.buffer.size;
            }
        }
    }

    // The Vulkan usage flags a resource must be created with: the union over the passes
    // that execute (a culled pass's usage must not force a flag on the resource).
    void collectUsageFlags(CompiledGraph& out, const std::vector<bool>& live) const
    {
        for (const ResolvedAccess& access : resolved_) {
            if (!live[access.pass]) continue;
            CompiledResource& res = out.resources[access.resource];
            switch (access.usage) {
            case Usage::ColorAttachment: res.imageUsage |= VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT; break;
            case Usage::DepthAttachment: res.imageUsage |= VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT; break;
            case Usage::Sampled: res.imageUsage |= VK_IMAGE_USAGE_SAMPLED_BIT; break;
            case Usage::Storage:
                res.imageUsage |= VK_IMAGE_USAGE_STORAGE_BIT;
                res.bufferUsage |= VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
                break;
            case Usage::TransferSrc:
                res.imageUsage |= VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
                res.bufferUsage |= VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
                break;
            case Usage::TransferDst:
                res.imageUsage |= VK_IMAGE_USAGE_TRANSFER_DST_BIT;
                res.bufferUsage |= VK_BUFFER_USAGE_TRANSFER_DST_BIT;
                break;
            case Usage::UniformBuffer: res.bufferUsage |= VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT; break;
            case Usage::VertexBuffer: res.bufferUsage |= VK_BUFFER_USAGE_VERTEX_BUFFER_BIT; break;
            case Usage::IndexBuffer: res.bufferUsage |= VK_BUFFER_USAGE_INDEX_BUFFER_BIT; break;
            case Usage::IndirectBuffer: res.bufferUsage |= VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT; break;
            case Usage::HostRead:
            case Usage::HostWrite: res.hostVisible = true; break;
            }
        }
        // Vulkan wants some usage on every buffer: one that only host passes touch (a
        // hand-over between two of them) gets the transfer usages.
        for (CompiledResource& res : out.resources)
            if (!res.isImage && res.hostVisible && res.bufferUsage == 0)
                res.bufferUsage = VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
        // Marked outputs are read after the frame (PNG, metrics, tests): a copy reads them.
        for (CompiledResource& res : out.resources)
            if (res.markedOutput) {
                if (res.isImage) res.imageUsage |= VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
                else res.bufferUsage |= VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
            }
    }

    void computeLifetimes(CompiledGraph& out) const
    {
        for (uint32_t i = 0; i < out.passes.size(); ++i)
            for (const ResourceUse& use : out.passes[i].uses) {
                CompiledResource& res = out.resources[use.resource];
                if (res.firstUse < 0) res.firstUse = int(i);
                res.lastUse = int(i);
            }
        // A marked output is read after the graph (presented, read back): its memory must
        // survive to the end of the frame.
        for (CompiledResource& res : out.resources)
            if (res.markedOutput && res.firstUse >= 0) res.lastUse = int(out.passes.size()) - 1;
    }

    // Greedy interval assignment: in order of first use (larger first on ties), take the
    // smallest free slot that fits, else grow the largest free slot, else open a slot.
    // Host-visible buffers and device-local resources never share a slot: they live in
    // different kinds of memory.
    static void assignMemorySlots(CompiledGraph& out)
    {
        std::vector<uint32_t> transient;
        for (uint32_t r = 0; r < out.resources.size(); ++r)
            if (!out.resources[r].imported && out.resources[r].firstUse >= 0) transient.push_back(r);
        auto aligned = [&](uint32_t r) {
            const CompiledResource& res = out.resources[r];
            return alignUp(res.sizeBytes, res.isImage ? kImageAlignment : kBufferAlignment);
        };
        std::stable_sort(transient.begin(), transient.end(), [&](uint32_t a, uint32_t b) {
            const int fa = out.resources[a].firstUse, fb = out.resources[b].firstUse;
            return fa != fb ? fa < fb : aligned(a) > aligned(b);
        });
        std::vector<int> busyUntil;  // last use of each slot's latest member
        for (uint32_t r : transient) {
            CompiledResource& res = out.resources[r];
            const VkDeviceSize need = aligned(r);
            int best = -1;
            int largest = -1;
            for (int s = 0; s < int(out.memorySlots.size()); ++s) {
                if (busyUntil[s] >= res.firstUse || out.memorySlots[s].hostVisible != res.hostVisible) continue;
                const VkDeviceSize size = out.memorySlots[s].sizeBytes;
                if (size >= need && (best < 0 || size < out.memorySlots[best].sizeBytes)) best = s;
                if (largest < 0 || size > out.memorySlots[largest].sizeBytes) largest = s;
            }
            if (best < 0) best = largest;
            if (res.persistent) best = -1;  // a slot of its own, never reused
            if (best < 0) {
                best = int(out.memorySlots.size());
                out.memorySlots.emplace_back().hostVisible = res.hostVisible;
                busyUntil.push_back(-1);
            }
            MemorySlot& slot = out.memorySlots[best];
            slot.sizeBytes = std::max(slot.sizeBytes, need);
            slot.resources.push_back(r);
            busyUntil[best] = res.persistent ? std::numeric_limits<int>::max() : res.lastUse;
            res.memorySlot = best;
            out.transientBytesUnaliased += need;
        }
        for (const MemorySlot& slot : out.memorySlots) out.transientBytesAliased += slot.sizeBytes;
    }

    void deriveBarriers(CompiledGraph& out) const
    {
        std::vector<ResourceState> state(resources_.size());
        for (uint32_t r = 0; r < resources_.size(); ++r)
            if (imported(r)) {
                // Unknown work outside the graph touched it last: wait for all of it.
                state[r].layout = decl(r).isImage ? decl(r).image.initialLayout : VK_IMAGE_LAYOUT_UNDEFINED;
                state[r].writeStage = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
                state[r].writeAccess = VK_ACCESS_2_MEMORY_WRITE_BIT;
            }
        // A persistent resource holds the last frame's contents, in the layout of its last
        // use then (the executor puts a new one there before its first frame); the last
        // frame's work on it must finish first.
        for (const CompiledPass& pass : out.passes)
            for (const ResourceUse& use : pass.uses)
                if (out.resources[use.resource].persistent) {
                    state[use.resource].layout = use.scope.layout;
                    state[use.resource].writeStage = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
                    state[use.resource].writeAccess = VK_ACCESS_2_MEMORY_WRITE_BIT;
                }
        // The resource that used an aliased slot before: its last accesses must finish
        // before the next resource in the slot overwrites the memory.
        std::vector<int> previousInSlot(resources_.size(), -1);
        for (const MemorySlot& slot : out.memorySlots)
            for (size_t i = 1; i < slot.resources.size(); ++i)
                previousInSlot[slot.resources[i]] = int(slot.resources[i - 1]);

        for (CompiledPass& pass : out.passes)
            for (const ResourceUse& use : pass.uses) {
                ResourceState& st = state[use.resource];
                if (!st.touched && previousInSlot[use.resource] >= 0) {
                    const ResourceState& prev = state[size_t(previousInSlot[use.resource])];
                    st.writeStage = prev.writeStage;
                    st.writeAccess = prev.writeAccess;
                    st.readStages = prev.readStages;
                }
                st.touched = true;
                if (auto barrier = nextBarrier(st, use)) pass.barriersBefore.push_back(*barrier);
            }
        restoreImportedLayouts(out, state);
        makeReadBacksVisible(out, state);
    }

    void makeReadBacksVisible(CompiledGraph& out, const std::vector<ResourceState>& state) const
    {
        std::vector<bool> written(resources_.size(), false);
        for (const CompiledPass& pass : out.passes)
            for (const ResourceUse& use : pass.uses) written[use.resource] = written[use.resource] || use.writes;
        for (uint32_t r = 0; r < resources_.size(); ++r) {
            if (!decl(r).readBack || !written[r]) continue;
            const ResourceState& st = state[r];
            out.barriersAfter.push_back(Barrier{r, false, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_UNDEFINED,
                                                st.writeStage | st.readStages, st.writeAccess,
                                                VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT});
        }
    }

    void restoreImportedLayouts(CompiledGraph& out, std::vector<ResourceState>& state) const
    {
        for (uint32_t r = 0; r < resources_.size(); ++r) {
            if (!decl(r).isImage) continue;
            ResourceState& st = state[r];
            const VkImageLayout initial = decl(r).image.initialLayout;
            if (imported(r) && initial != VK_IMAGE_LAYOUT_UNDEFINED && st.layout != initial) {
                out.barriersAfter.push_back(Barrier{r, true, st.layout, initial, st.writeStage | st.readStages,
                                                    st.writeAccess, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                                                    VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT});
                st.layout = initial;
            }
            out.resources[r].finalLayout = st.layout;
        }
    }

    std::optional<Barrier> nextBarrier(ResourceState& st, const ResourceUse& use) const
    {
        const bool image = decl(use.resource).isImage;
        const AccessScope& cur = use.scope;
        const bool layoutChange = image && st.layout != cur.layout;
        bool needed = false;
        // Earlier reads are included so that the barrier chains after them: write-after-
        // read needs an execution dependency only, hence no access bits for them.
        const VkPipelineStageFlags2 srcStage = st.writeStage | st.readStages;
        if (use.writes || layoutChange) {
            needed = layoutChange || srcStage != VK_PIPELINE_STAGE_2_NONE;
        } else {
            const bool visible = std::any_of(st.visibleTo.begin(), st.visibleTo.end(), [&](const AccessScope& v) {
                return (cur.stage & ~v.stage) == 0 && (cur.access & ~v.access) == 0;
            });
            needed = st.writeStage != VK_PIPELINE_STAGE_2_NONE && !visible;
        }
        std::optional<Barrier> barrier;
        if (needed)
            barrier = Barrier{use.resource, image, st.layout, image ? cur.layout : VK_IMAGE_LAYOUT_UNDEFINED,
                              srcStage, st.writeAccess, cur.stage, cur.access};
        if (use.writes) {
            st.writeStage = cur.stage;
            st.writeAccess = cur.access & kWriteAccess;
            st.readStages = VK_PIPELINE_STAGE_2_NONE;
            st.visibleTo.clear();
        } else {
            if (needed) st.visibleTo.push_back(cur);
            st.readStages |= cur.stage;
        }
        st.layout = image ? cur.layout : VK_IMAGE_LAYOUT_UNDEFINED;
        return barrier;
    }

    const std::vector<RenderGraph::ResourceDecl>& resources_;
    const std::vector<RenderGraph::PassDecl>& passes_;
    const bool keepUnchanged_;
    std::vector<std::vector<ResourceUse>> uses_;
    std::vector<std::vector<uint32_t>> preds_;
    std::vector<std::vector<uint32_t>> succs_;
    std::vector<std::vector<uint32_t>> writers_;
    struct ResolvedAccess {
        uint32_t pass;
        uint32_t resource;
        Usage usage;
    };
    std::vector<ResolvedAccess> resolved_;
};

std::shared_ptr<const CompiledGraph> RenderGraph::compile()
{
    if (compiled_ && compiledVersion_ == version_) return compiled_;
    compiled_ = GraphCompiler(resources_, passes_, keepUnchanged_).run();
    compiledVersion_ = version_;
    return compiled_;
}

void verifyAliasing(const CompiledGraph& graph)
{
    for (size_t s = 0; s < graph.memorySlots.size(); ++s) {
        const MemorySlot& slot = graph.memorySlots[s];
        std::vector<uint32_t> members = slot.resources;
        std::sort(members.begin(), members.end(), [&](uint32_t a, uint32_t b) {
            return graph.resources[a].firstUse < graph.resources[b].firstUse;
        });
        for (size_t i = 0; i < members.size(); ++i) {
            const CompiledResource& res = graph.resources[members[i]];
            if (res.sizeBytes > slot.sizeBytes || res.imported || res.firstUse < 0)
                throw Error(fmt::format("render graph: aliasing invariant violated: '{}' cannot live in slot {} "
                                        "({} bytes)",
                                        res.name, s, slot.sizeBytes));
            if (res.hostVisible != slot.hostVisible)
                throw Error(fmt::format("render graph: aliasing invariant violated: {} '{}' in {} slot {}",
                                        res.hostVisible ? "host-visible" : "device-local", res.name,
                                        slot.hostVisible ? "host-visible" : "device-local", s));
            if (i == 0) continue;
            const CompiledResource& prev = graph.resources[members[i - 1]];
            if (prev.lastUse >= res.firstUse)
                throw Error(fmt::format("render graph: aliasing invariant violated: '{}' (passes {}..{}) and '{}' "
                                        "(passes {}..{}) share slot {} with overlapping lifetimes",
                                        prev.name, prev.firstUse, prev.lastUse, res.name, res.firstUse, res.lastUse,
                                        s));
        }
    }
}

} // namespace penumbra::graph
