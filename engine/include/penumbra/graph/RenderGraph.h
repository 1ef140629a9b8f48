#pragma once
// The pass scheduler's CPU core (Granite-style: declare, compile, then execute).
// Passes declare which images and buffers they read and write, with a usage from which
// the layout and the synchronization2 stage/access masks follow. compile() orders the
// passes, culls those whose outputs nothing needs, computes lifetimes, aliases transient
// memory and derives the barriers. graph/GraphExecutor.h executes a compiled graph: it
// allocates the transient resources, inserts the barriers and runs each pass's execute
// callback (GPU passes between a debug label and two GPU timestamps; host passes on the
// CPU, between two submissions).
#include <vulkan/vulkan.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <unordered_set>
#include <vector>

namespace penumbra::graph {

// Where a pass runs. Host passes run their callback on the CPU between GPU work: the
// executor submits the GPU passes before one and waits for them, runs it, and records
// the rest in a new submission (a CPU ray tracer between the G-buffer and shading). A
// host pass touches only buffers, through Usage::HostRead / HostWrite, which the
// executor places in host-visible memory and maps.
enum class QueueKind { Graphics, Compute, Transfer, Host };

// How a pass touches a resource. The direction (read or write) is given separately;
// `usageAllows` says which directions a usage permits.
enum class Usage {
    ColorAttachment,  // image, write
    DepthAttachment,  // image, read (depth test only) or write
    Sampled,          // image, read (combined image sampler / sampled image)
    Storage,          // image or buffer, read or write
    TransferSrc,      // image or buffer, read
    TransferDst,      // image or buffer, write
    UniformBuffer,    // buffer, read
    VertexBuffer,     // buffer, read
    IndexBuffer,      // buffer, read
    IndirectBuffer,   // buffer, read
    HostRead,         // buffer, read by a host pass (PassContext::hostMemory)
    HostWrite,        // buffer, written by a host pass (PassContext::hostMemory)
};

enum class Access { Read, Write };

struct ImageDesc {
    std::string name;
    uint32_t width = 0;
    uint32_t height = 0;
    VkFormat format = VK_FORMAT_UNDEFINED;
    // Imported images live outside the graph (swapchain, history, a technique's
    // persistent map): they are never aliased and may be read without a writer.
    bool imported = false;
    VkImageLayout initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;  // imported images only
    // Array layers (gpu::ImageDesc::layers): barriers and clears cover every layer.
    uint32_t layers = 1;

    bool operator==(const ImageDesc&) const = default;
};

struct BufferDesc {
    std::string name;
    VkDeviceSize size = 0;
    bool imported = false;

    bool operator==(const BufferDesc&) const = default;
};

// Layout (images) and synchronization2 scope of one access.
struct AccessScope {
    VkImageLayout layout = VK_IMAGE_LAYOUT_UNDEFINED;
    VkPipelineStageFlags2 stage = VK_PIPELINE_STAGE_2_NONE;
    VkAccessFlags2 access = VK_ACCESS_2_NONE;

    bool operator==(const AccessScope&) const = default;
};

// The scope of `usage` in `direction` for a pass on `queue`. `depthFormat` picks the
// depth read-only layout for sampled depth images. Throws on a usage/direction mismatch.
AccessScope deriveScope(Usage usage, Access direction, QueueKind queue, bool isImage, bool depthFormat);

// A barrier to record before a pass. Images: a layout transition (old may equal new);
// buffers: a buffer memory barrier over the whole buffer.
struct Barrier {
    uint32_t resource = 0;  // index into CompiledGraph::resources
    bool isImage = true;
    VkImageLayout oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    VkImageLayout newLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    VkPipelineStageFlags2 srcStage = VK_PIPELINE_STAGE_2_NONE;
    VkAccessFlags2 srcAccess = VK_ACCESS_2_NONE;
    VkPipelineStageFlags2 dstStage = VK_PIPELINE_STAGE_2_NONE;
    VkAccessFlags2 dstAccess = VK_ACCESS_2_NONE;
};

// One pass's combined accesses to one resource.
struct ResourceUse {
    uint32_t resource = 0;  // index into CompiledGraph::resources
    bool reads = false;
    bool writes = false;
    AccessScope scope;
};

struct CompiledPass {
    std::string name;
    QueueKind queue = QueueKind::Graphics;
    uint32_t declarationIndex = 0;
    std::vector<ResourceUse> uses;
    std::vector<Barrier> barriersBefore;
    // The states its results depend on besides what it reads (PassBuilder::dependsOn):
    // the executor keeps them while those states and its inputs are unchanged. Empty: it
    // runs every frame (it declared none, or it shares a resource it writes with a pass
    // that runs every frame).
    std::vector<std::string> keptWhile;
};

struct CulledPass {
    std::string name;
    std::string reason;
};

struct CompiledResource {
    std::string name;
    bool isImage = true;
    bool imported = false;
    bool markedOutput = false;
    uint32_t width = 0, height = 0;
    uint32_t layers = 1;  // array layers
    VkFormat format = VK_FORMAT_UNDEFINED;
    VkDeviceSize sizeBytes = 0;  // estimate: texel blocks × block size, or buffer size
    int firstUse = -1;           // pass index in CompiledGraph::passes; -1: unused
    int lastUse = -1;            // marked outputs: the last pass
    int memorySlot = -1;         // transient and used only
    // Every usage that any executed pass declares, for creating the resource.
    VkImageUsageFlags imageUsage = 0;
    VkBufferUsageFlags bufferUsage = 0;
    // Images: the layout after the frame, including CompiledGraph::barriersAfter (an
    // untouched imported image stays in its initial layout). UNDEFINED for buffers.
    VkImageLayout finalLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    // Buffers a host pass reads or writes: placed in host-visible, coherent memory and
    // mapped; never aliased with device-local resources. Read-back buffers too (bound to
    // a host-visible buffer of their owner's).
    bool hostVisible = false;
    bool readBack = false;  // RenderGraph::readBack
    // Written by a pass that may be kept (CompiledPass::keptWhile): its contents must
    // survive from frame to frame, so it has memory of its own (a slot no other resource
    // shares) and starts each frame in the layout it ended the last one in.
    bool persistent = false;
};

// A block of device memory shared by transient resources with disjoint lifetimes.
struct MemorySlot {
    VkDeviceSize sizeBytes = 0;
    std::vector<uint32_t> resources;  // in order of first use
    bool hostVisible = false;         // holds host-visible buffers only (else device-local resources only)
};

struct CompiledGraph {
    std::vector<CompiledPass> passes;  // execution order
    std::vector<CulledPass> culled;
    std::vector<CompiledResource> resources;  // declaration order
    std::vector<MemorySlot> memorySlots;
    // After the last pass: imported images whose declared initialLayout is not UNDEFINED
    // go back to it, so that every frame (and the owner outside the graph) starts from
    // the declared state (the destination scope is all commands: whatever comes next);
    // read-back buffers' last writes are made visible to the host (HOST stage, HOST_READ).
    std::vector<Barrier> barriersAfter;
    VkDeviceSize transientBytesUnaliased = 0;  // sum of aligned transient sizes
    VkDeviceSize transientBytesAliased = 0;    // sum of slot sizes

    std::string toText() const;
    std::string toDot() const;
};

// Throws penumbra::Error if two resources of one slot overlap in lifetime or a slot is
// smaller than a member. compile() runs it on its own result.
void verifyAliasing(const CompiledGraph& graph);

class RenderGraph;
class PassContext;  // graph/PassContext.h

// Records a pass's commands. Called once per executed frame, only for passes that
// survived culling, with the resources the pass declared bound in `PassContext`.
using ExecuteFn = std::function<void(PassContext&)>;

// A handle for declaring a pass's accesses; valid while its RenderGraph lives.
class PassBuilder {
public:
    PassBuilder& read(std::string_view resource, Usage usage);
    PassBuilder& write(std::string_view resource, Usage usage);
    // The pass's command recording. Setting it does not change the graph's structure
    // (the compiled graph stays cached).
    PassBuilder& execute(ExecuteFn fn);
    // Declares that the pass's results depend only on what it reads and on `state` (and
    // any other state it names): something outside the graph that its callback uses (a
    // light and the casters it sees, the camera), whose version the frame's owner sets
    // with RenderGraph::setState. The executor then keeps the pass's results instead of
    // running it while, since it last ran, every such state kept its version, nothing it
    // reads was written again and nothing it writes was touched (GraphExecutor::execute).
    // What it writes is persistent (CompiledResource::persistent). A pass that declares
    // no state runs every frame, and so does one that shares a resource it writes with
    // such a pass.
    PassBuilder& dependsOn(std::string_view state);

private:
    friend class RenderGraph;
    PassBuilder(RenderGraph& graph, uint32_t pass) : graph_(&graph), pass_(pass) {}
    RenderGraph* graph_;
    uint32_t pass_;
};

class RenderGraph {
public:
    // Declaring a resource again with the same description is allowed (a frame may
    // re-declare what it needs); a different description throws.
    void declareImage(const ImageDesc& desc);
    void declareBuffer(const BufferDesc& desc);
    PassBuilder addPass(std::string name, QueueKind queue, bool sideEffect = false);
    void markOutput(std::string_view resource);
    // The CPU reads `buffer` after the frame (a technique's counters, an analysis the next
    // frame's CPU work uses): the passes that write it run (it counts as an output), and
    // after the last pass a barrier makes their writes visible to the host, so that its
    // owner reads the mapped memory once the frame has finished (GraphExecutor::execute
    // waits for it), with no wait of its own inside the frame. Only an imported buffer,
    // bound to a host-visible gpu::Buffer: a transient one's memory is not kept after the
    // frame. Throws penumbra::Error for an undeclared resource, an image or a transient
    // buffer.
    void readBack(std::string_view buffer);

    // Orders, culls, computes lifetimes, aliases and derives barriers. Returns the
    // cached result while the declaration has not changed since the last compile.
    // Throws penumbra::Error for cycles, reads of never-written non-imported resources,
    // unordered writers, undeclared resources and conflicting accesses in one pass.
    std::shared_ptr<const CompiledGraph> compile();

    uint64_t version() const { return version_; }

    // The version of a state that passes depend on (PassBuilder::dependsOn); setting it
    // does not change the declaration (the compiled graph stays cached). A state never
    // set has no version: the passes that depend on it run every frame.
    void setState(std::string_view state, uint64_t version);
    std::optional<uint64_t> stateVersion(std::string_view state) const;
    // false: no pass is ever kept, whatever it depends on, and nothing is persistent (every
    // transient may be aliased): every pass runs every frame, in the least memory.
    void setKeepUnchanged(bool keep);

    // Whether any declared pass writes `resource` (before culling).
    bool isWritten(std::string_view resource) const;
    // The declared images that some pass writes, in declaration order (before culling):
    // what a debug view may ask for by name.
    std::vector<std::string> writtenImages() const;

    // The execute callback of the pass declared `declarationIndex`-th (see
    // CompiledPass::declarationIndex); empty when none was set.
    const ExecuteFn& executeFn(uint32_t declarationIndex) const { return passes_.at(declarationIndex).execute; }

private:
    friend class PassBuilder;
    struct ResourceDecl {
        bool isImage = true;
        ImageDesc image;
        BufferDesc buffer;
        bool markedOutput = false;
        bool readBack = false;
    };
    struct AccessDecl {
        std::string resource;
        Usage usage;
        Access direction;
    };
    struct PassDecl {
        std::string name;
        QueueKind queue;
        bool sideEffect;
        std::vector<AccessDecl> accesses;
        ExecuteFn execute;
        std::vector<std::string> states;  // dependsOn
    };

    void addAccess(uint32_t pass, std::string_view resource, Usage usage, Access direction);
    ResourceDecl* findResource(std::string_view name);
    void declare(ResourceDecl decl, const std::string& name);

    std::vector<ResourceDecl> resources_;
    std::vector<PassDecl> passes_;
    std::unordered_map<std::string, uint32_t> resourceIndex_;
    std::unordered_set<std::string> passNames_;
    std::unordered_map<std::string, uint64_t> states_;
    bool keepUnchanged_ = true;
    uint64_t version_ = 0;
    uint64_t compiledVersion_ = 0;
    std::shared_ptr<const CompiledGraph> compiled_;

    friend class GraphCompiler;
};

} // namespace penumbra::graph
