// Deep shadow maps (README.md next to this file; Fürst, Mattausch, Scherzer, "Real-Time
// Deep Shadow Maps"): every caster fragment the light sees goes into a per-texel linked
// list (fragments.frag), the lists are sorted into transmittance functions and truncated
// (sort.comp), linked to their neighbours (links.comp), and every G-buffer pixel reads
// the transmittance at its depth, filtered by PCF or the exponential test
// (visibility.comp). Translucent (BLEND) casters attenuate by 1 - alpha, opaque and
// alpha-masked ones (above their cutoff) block: one structure for both.
#include "penumbra/core/Error.h"
#include "penumbra/gpu/Context.h"
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/gpu/Resources.h"
#include "penumbra/graph/PassContext.h"
#include "penumbra/graph/RenderGraph.h"
#include "penumbra/plugin/ClearPass.h"
#include "penumbra/plugin/ComputePipeline.h"
#include "penumbra/plugin/DebugViews.h"
#include "penumbra/plugin/Plugin.h"
#include "penumbra/plugin/ShadowMapParams.h"
#include "penumbra/plugin/Technique.h"
#include "penumbra/plugin/VisibilityPass.h"
#include "penumbra/render/ShadowMap.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <iterator>
#include <string>
#include <vector>

namespace penumbra::deep {
namespace {

using plugin::ParamType;

// Parameter `lookup`, in ParamSpec choice order (visibility.comp LOOKUP).
enum class Lookup : uint32_t { Linked, BruteForce };
constexpr const char* kLookupNames[] = {"linked", "brute_force"};
// Parameter `bias_mode`: a depth bias on every stored fragment (fragments.frag, the
// rasterizer's constant and slope-scaled formula), or the receiver moved along its normal
// (visibility.comp SHADOW_RECEIVER_BIAS 1).
enum class BiasMode : uint32_t { Slope, NormalOffset };
constexpr const char* kBiasModeNames[] = {"slope", "normal_offset"};
// Parameter `filter` (visibility.comp FILTER).
enum class Filter : uint32_t { Dsm, Edsm, FirstFragment };
constexpr const char* kFilterNames[] = {"dsm", "edsm", "first_fragment"};

constexpr uint32_t kNodeBytes = 24;        // deep_lists.glsl DeepNode
constexpr uint32_t kSortCapacity = 256;    // deep_lists.glsl DEEP_SORT_CAPACITY
constexpr uint32_t kComplexityBins = 16;   // deep_counters.glsl DEEP_COMPLEXITY_BINS
constexpr int kMaxPoolMib = 4096;  // 178,956,970 nodes: the counters (uint32) cannot wrap first

// Nodes in a pool of `mib` MiB.
uint32_t nodesIn(uint32_t mib) { return uint32_t((uint64_t(mib) << 20) / kNodeBytes); }

const plugin::ParamSpec kParams[] = {
    plugin::shadowResolutionParam(1024, 8192),
    {"pool_mib", ParamType::Int, 64, 1, kMaxPoolMib, "MiB",
     "the fragment pool at the start: 24 bytes a fragment; a frame that needs more grows it and is drawn again"},
    {"max_pool_mib", ParamType::Int, 1024, 1, kMaxPoolMib, "MiB",
     "the largest the pool grows to; fragments past it are dropped, counted and warned about"},
    {"epsilon", ParamType::Float, 0.001, 0, 0.5, "",
     "truncation: a list ends at its first node whose transmittance is at most epsilon (error at most epsilon)"},
    plugin::oddKernelParam("pcf_kernel", 1, 7, "taps per side of the filter box, odd: 1, 3, 5, 7"),
    {"lookup", ParamType::Enum, double(Lookup::Linked), 0, 0, "",
     "linked: taps start at their neighbour's links (3.5); brute_force: every tap searches its list from the head",
     kLookupNames, uint32_t(std::size(kLookupNames))},
    {"filter", ParamType::Enum, double(Filter::Dsm), 0, 0, "",
     "dsm: a node shadows what lies behind it fully; edsm: the node just in front by the exponential test; "
     "first_fragment: a binary compare with each list's first node (a shadow map built from the lists, for "
     "measuring)",
     kFilterNames, uint32_t(std::size(kFilterNames))},
    {"esm_exponent", ParamType::Float, 80, 0, 1e4, "",
     "filter edsm: c of 1 - e^{-c (t_receiver - t_node)}, t the linear depth along the face in [0, 1]"},
    {"bias_mode", ParamType::Enum, double(BiasMode::Slope), 0, 0, "",
     "slope: every stored fragment moved away from the light by depth_bias and slope_bias (the hard plugin's "
     "default); normal_offset: the receiver moved along its normal instead",
     kBiasModeNames, uint32_t(std::size(kBiasModeNames))},
    plugin::kShadowDepthBiasParam,
    plugin::slopeBiasParam("bias_mode slope: times the fragment's depth slope, per texel of the filter's width"),
    {"normal_offset", ParamType::Float, 1.0, 0, 64, "texels",
     "bias_mode normal_offset: the receiver's offset along its normal, in texels at the receiver, per texel of the "
     "filter's width"},
    {"debug_depth", ParamType::Float, 0.5, 0, 1, "",
     "debug image transmittance: the linear depth along the face (0 near, 1 far) it reads each list at"},
};

// The debug images (debug.comp), R32F over the atlas.
constexpr plugin::DebugImage kDebugImages[] = {
    {"depth_complexity", "complexityOut"}, {"list_length", "lengthOut"}, {"transmittance", "transmittanceOut"}};

struct Settings {
    uint32_t resolution = 1024;
    uint32_t poolMib = 64;
    uint32_t maxPoolMib = 1024;
    float epsilon = 0.001f;
    uint32_t pcfKernel = 1;
    Lookup lookup = Lookup::Linked;
    Filter filter = Filter::Dsm;
    float esmExponent = 80.0f;
    BiasMode biasMode = BiasMode::Slope;
    float depthBias = 4.0f;
    float slopeBias = 2.0f;
    float normalOffsetTexels = 1.0f;
    float debugDepth = 0.5f;
};

Settings readSettings(const plugin::ParamValues& params)
{
    Settings s;
    s.resolution = uint32_t(params.getInt("resolution"));
    s.poolMib = uint32_t(params.getInt("pool_mib"));
    s.maxPoolMib = uint32_t(params.getInt("max_pool_mib"));
    if (s.maxPoolMib < s.poolMib) {
        throw ConfigError(fmt::format("deep: max_pool_mib: the pool grows from pool_mib = {} MiB up to max_pool_mib, "
                                      "which is {} MiB: set it to at least {}",
                                      s.poolMib, s.maxPoolMib, s.poolMib));
    }
    s.epsilon = params.getFloat("epsilon");
    s.pcfKernel = uint32_t(params.getInt("pcf_kernel"));
    s.lookup = Lookup(params.getEnumIndex("lookup"));
    s.filter = Filter(params.getEnumIndex("filter"));
    s.esmExponent = params.getFloat("esm_exponent");
    s.biasMode = BiasMode(params.getEnumIndex("bias_mode"));
    s.depthBias = params.getFloat("depth_bias");
    s.slopeBias = params.getFloat("slope_bias");
    s.normalOffsetTexels = params.getFloat("normal_offset");
    s.debugDepth = params.getFloat("debug_depth");
    return s;
}

// deep_counters.glsl DeepCounters.
struct Counters {
    uint32_t fragments = 0;
    uint32_t kept = 0;
    uint32_t overSortCap = 0;
    uint32_t longest = 0;
    std::array<uint32_t, kComplexityBins> complexity{};
};
static_assert(sizeof(Counters) == 4 * (4 + kComplexityBins));

struct FragmentPush {
    glm::mat4 viewProj;  // engine/shadow_depth.vert
    uint32_t capacity;   // fragments.frag
    float depthBias;     // in r, the depth format's resolution at the fragment
    float slopeBias;     // times the fragment's depth slope
};
struct SortPush {
    float epsilon;
    uint32_t capacity;
};
struct VisibilityPush {
    float normalOffsetTexels;
    float esmExponent;
};

class DeepShadow final : public plugin::Technique {
public:
    explicit DeepShadow(const plugin::TechniqueSetup& setup);
    DeepShadow(const DeepShadow&) = delete;
    DeepShadow& operator=(const DeepShadow&) = delete;

    void update(const scene::Light& light, const scene::Aabb& sceneBounds) override;
    void registerPasses(graph::RenderGraph& graph, const plugin::LightPassIo& io) override;
    std::vector<plugin::TechniqueFigure> figures() const override;
    bool wantsRedraw() override;

private:
    struct Names {
        std::string heads, nodes, counters, lengths, opaque, lastCounters;
    };
    void recordFragments(const graph::PassContext& pass, const Names& names) const;
    void addLinksPass(graph::RenderGraph& graph, const plugin::LightPassIo& io, const Names& names,
                      const std::string& name);
    bool usesLinks() const
    {
        return settings_.pcfKernel > 1 && settings_.lookup == Lookup::Linked && settings_.filter != Filter::FirstFragment;
    }
    uint32_t capacity() const { return capacity_; }
    Counters lastCounters() const;

    gpu::Context& context_;
    const render::Casters& casters_;
    const uint32_t lightIndex_;
    const std::string prefix_;  // "light0.deep."
    const Settings settings_;
    render::ShadowMap shadowMap_;
    gpu::Pipeline fragments_;
    gpu::Pipeline sort_;
    gpu::Pipeline links_;
    gpu::Pipeline visibility_;
    plugin::DebugViewPass debugViews_;
    gpu::Buffer counters_;  // host-visible, read back through the graph: the last frame's Counters
    uint32_t capacity_ = 0;  // nodes in the pool: pool_mib's, grown up to max_pool_mib's
    uint32_t deviceMaxMib_ = 0;  // the largest pool the device binds
    bool warnedOverflow_ = false;
};

DeepShadow::DeepShadow(const plugin::TechniqueSetup& setup)
    : context_(setup.context),
      casters_(setup.casters),
      lightIndex_(setup.lightIndex),
      prefix_(setup.prefix),
      settings_(readSettings(setup.params)),
      shadowMap_(setup, settings_.resolution, "deep",
                 settings_.pcfKernel > 1 ? render::kernelGuardTexels(0.5f * float(settings_.pcfKernel), settings_.resolution)
                                         : 0u),
      debugViews_(setup, plugin::computePipelineDesc(setup, "debug_views", "debug.comp", shadowMap_.shaderDefines(),
                                                     sizeof(float)))
{
    // The pool is one storage buffer: the device binds at most maxStorageBufferRange bytes
    // of it (lavapipe: 128 MiB, 5,592,405 nodes).
    deviceMaxMib_ = uint32_t(std::min<uint64_t>(context_.properties().limits.maxStorageBufferRange >> 20, kMaxPoolMib));
    if (settings_.poolMib > deviceMaxMib_) {
        throw ConfigError(fmt::format("deep: pool_mib: {} MiB is more than this device binds as one storage buffer "
                                      "({} MiB, maxStorageBufferRange); set pool_mib to at most {}",
                                      settings_.poolMib, deviceMaxMib_, deviceMaxMib_));
    }
    const float width = float(settings_.pcfKernel);
    // Only the lookups read the lists, within the filter's half width and the normal
    // offset of the receiver's texel.
    shadowMap_.setReadByLookupsOnly(true);
    const bool normalOffset = settings_.biasMode == BiasMode::NormalOffset;
    shadowMap_.setFootprint(0.5f * width + (normalOffset ? settings_.normalOffsetTexels * width : 0.0f));
    // With the bias in the stored depths every tap compares a list with the receiver's own
    // depth, within (k - 1) / 2 texels of its texel: a fragment behind every receiver that
    // reads its texel changes no transmittance, and receiver-mask culling may skip its
    // caster (render/Casters.h compareTapRadius). The culling sees no bias (the shader adds
    // it), so it keeps a little more than it could.
    if (!normalOffset) shadowMap_.setOwnDepthCompare(int32_t(settings_.pcfKernel - 1) / 2);
    const std::vector<gpu::ShaderDefine> mapDefines = shadowMap_.shaderDefines();

    gpu::GraphicsPipelineDesc f;
    f.name = setup.local("fragments");
    f.vertexShader = "engine/shadow_depth.vert";
    f.fragmentShader = "fragments.frag";
    f.defines = {{"ALPHA_MASK", "1"}};
    f.pushConstantBytes = sizeof(FragmentPush);
    f.vertexLayout = casters_.positionUvLayout();
    // Tested against the opaque casters' depth (early fragment tests, no write): what
    // lies behind the nearest opaque surface never reaches the shader.
    f.depthFormat = render::kShadowDepthFormat;
    f.depthCompare = VK_COMPARE_OP_GREATER_OR_EQUAL;
    f.depthWrite = false;
    f.cullMode = VK_CULL_MODE_NONE;  // both sides of every triangle cast, as in the depth maps
    fragments_ = gpu::Pipeline(context_, setup.shaders, f);

    sort_ = plugin::createComputePipeline(setup, "sort", "sort.comp", {}, sizeof(SortPush));
    if (usesLinks()) links_ = plugin::createComputePipeline(setup, "links", "links.comp", {}, sizeof(uint32_t));
    std::vector<gpu::ShaderDefine> lookup = {{"PCF_KERNEL", std::to_string(settings_.pcfKernel)},
                                             {"LOOKUP", std::to_string(uint32_t(settings_.lookup))},
                                             {"FILTER", std::to_string(uint32_t(settings_.filter))},
                                             {"RECEIVER_BIAS", normalOffset ? "1" : "0"}};
    std::ranges::copy(mapDefines, std::back_inserter(lookup));
    visibility_ = plugin::createComputePipeline(setup, "visibility", "visibility.comp", lookup, sizeof(VisibilityPush));
    capacity_ = nodesIn(settings_.poolMib);
    counters_ = gpu::Buffer(context_, sizeof(Counters), VK_BUFFER_USAGE_TRANSFER_DST_BIT, true,
                            setup.local("last_counters"));
    std::memset(counters_.mapped(), 0, sizeof(Counters));
}

void DeepShadow::update(const scene::Light& light, const scene::Aabb& sceneBounds)
{
    shadowMap_.update(light, sceneBounds);
}

// The last frame has finished (the executor waits for it) and its counters were made
// visible to the host (RenderGraph::readBack).
Counters DeepShadow::lastCounters() const
{
    Counters last;
    std::memcpy(&last, counters_.mapped(), sizeof(last));
    return last;
}

bool DeepShadow::wantsRedraw()
{
    const Counters last = lastCounters();
    if (last.fragments <= capacity_) return false;
    const uint32_t maxMib = std::min(settings_.maxPoolMib, deviceMaxMib_);
    const uint32_t most = nodesIn(maxMib);
    if (capacity_ < most) {
        // A quarter more than the frame asked for, in whole MiB: a light or camera that
        // moves a little does not grow it again at once.
        const uint64_t wanted = uint64_t(last.fragments) + last.fragments / 4;
        const uint32_t mib = uint32_t(std::min<uint64_t>((wanted * kNodeBytes + (1u << 20) - 1) >> 20, maxMib));
        spdlog::info("deep (light {}): pass '{}fragments' appended {} fragments to a pool of {}: the pool grows to {} "
                     "MiB and the frame is drawn again",
                     lightIndex_, prefix_, last.fragments, capacity_, mib);
        capacity_ = nodesIn(mib);
        return true;
    }
    if (!warnedOverflow_) {
        spdlog::warn("deep (light {}): pass '{}fragments' appended {} fragments to a pool of {} ({} MiB: {}): {} were "
                     "dropped and their texels are lit too much; {}",
                     lightIndex_, prefix_, last.fragments, capacity_, maxMib,
                     maxMib < settings_.maxPoolMib ? "the most this device binds" : "max_pool_mib",
                     last.fragments - capacity_,
                     maxMib < settings_.maxPoolMib ? "lower the resolution" : "raise max_pool_mib");
        warnedOverflow_ = true;
    }
    return false;
}

std::vector<plugin::TechniqueFigure> DeepShadow::figures() const
{
    const Counters last = lastCounters();
    const double mib = 1.0 / double(1u << 20);
    const uint32_t stored = std::min(last.fragments, capacity_);
    std::vector<plugin::TechniqueFigure> f = {
        {"fragments", double(last.fragments), ""},
        {"dropped_fragments", double(last.fragments - stored), ""},
        {"pool_mib", double(capacity_) * kNodeBytes * mib, "MiB"},
        {"pool_used_mib", double(stored) * kNodeBytes * mib, "MiB"},
        {"nodes_kept", double(last.kept), ""},
        {"over_sort_capacity", double(last.overSortCap), ""},
        {"longest_list", double(last.longest), ""},
    };
    // Depth complexity: texels by fragment count, bin b holding 2^b .. 2^(b+1) - 1.
    for (uint32_t b = 0; b < kComplexityBins; ++b) {
        if (last.complexity[b] == 0) continue;
        const std::string range = b == 0 ? "1" : b + 1 == kComplexityBins ? fmt::format("{}+", 1u << b)
                                                                          : fmt::format("{}-{}", 1u << b, (2u << b) - 1);
        f.push_back({fmt::format("texels_with_{}_fragments", range), double(last.complexity[b]), "texels"});
    }
    return f;
}

void DeepShadow::recordFragments(const graph::PassContext& pass, const Names& names) const
{
    const VkCommandBuffer cmd = pass.cmd();
    const render::ShadowMapPlacement own{shadowMap_.frusta(), {0, 0}, 0};
    const render::ShadowFaceDraws draws = shadowMap_.faceDraws(pass, names.heads, {}, {&own, 1});
    VkRenderingAttachmentInfo depth{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
    depth.imageView = pass.image(names.opaque).view();
    depth.imageLayout = pass.layout(names.opaque);
    depth.loadOp = VK_ATTACHMENT_LOAD_OP_LOAD;
    depth.storeOp = VK_ATTACHMENT_STORE_OP_NONE;
    VkRenderingInfo info{VK_STRUCTURE_TYPE_RENDERING_INFO};
    info.renderArea = draws.area;
    info.layerCount = 1;
    info.pDepthAttachment = &depth;
    vkCmdBeginRendering(cmd, &info);
    casters_.countRenderedTexels(uint64_t(info.renderArea.extent.width) * info.renderArea.extent.height);
    fragments_.bind(cmd);
    const bool slope = settings_.biasMode == BiasMode::Slope;
    for (const render::ShadowFaceDraw& face : draws.faces) {
        vkCmdSetViewport(cmd, 0, 1, &face.viewport);
        vkCmdSetScissor(cmd, 0, 1, &face.scissor);
        const FragmentPush push{face.view.viewProj, capacity(), slope ? settings_.depthBias : 0.0f,
                                slope ? settings_.slopeBias * float(settings_.pcfKernel) : 0.0f};
        fragments_.pushConstants(cmd, &push, sizeof(push));
        casters_.draw(cmd, face.view, render::DrawFilter::All, [&](const gpu::Image& texture) {
            gpu::DescriptorPush()
                .storageBuffer("Instances", casters_.instanceBuffer())
                .storageBuffer("Materials", casters_.materialBuffer())
                .sampledImage("baseColorTexture", texture, casters_.textureSampler())
                .storageImage("heads", pass.image(names.heads))
                .storageBuffer("DeepNodes", pass.buffer(names.nodes))
                .storageBuffer("DeepCounters", pass.buffer(names.counters))
                .push(context_, cmd, fragments_);
        });
    }
    vkCmdEndRendering(cmd);
}

void DeepShadow::addLinksPass(graph::RenderGraph& graph, const plugin::LightPassIo& io, const Names& names,
                              const std::string& name)
{
    graph.addPass(name, graph::QueueKind::Compute)
        .dependsOn(io.lightState)
        .read(names.heads, graph::Usage::Storage)
        .read(names.lengths, graph::Usage::Storage)
        .read(names.nodes, graph::Usage::Storage)
        .write(names.nodes, graph::Usage::Storage)
        .execute([this, names](graph::PassContext& pass) {
            links_.bind(pass.cmd());
            gpu::DescriptorPush()
                .storageImage("heads", pass.image(names.heads))
                .storageImage("lengths", pass.image(names.lengths))
                .storageBuffer("DeepNodes", pass.buffer(names.nodes))
                .push(context_, pass.cmd(), links_);
            const uint32_t faceTexels = shadowMap_.faceTexels();
            links_.pushConstants(pass.cmd(), &faceTexels, sizeof(faceTexels));
            links_.dispatchOver(pass.cmd(), pass.image(names.heads));
        });
}

void DeepShadow::registerPasses(graph::RenderGraph& graph, const plugin::LightPassIo& io)
{
    const Names names{io.local("heads"),   io.local("nodes"),        io.local("counters"),
                      io.local("lengths"), io.local("opaque_depth"), io.local("last_counters")};
    // The nearest surface of the casters that let no light through, drawn with the lists'
    // own depths (no bias): the fragment pass keeps only what is in front of it or on it.
    shadowMap_.addOpaqueDepthPass(graph, names.opaque, {});
    const uint32_t w = shadowMap_.atlasWidth(), h = shadowMap_.atlasHeight();
    graph.declareImage({names.heads, w, h, VK_FORMAT_R32_UINT});
    graph.declareImage({names.lengths, w, h, VK_FORMAT_R32_UINT});
    graph.declareBuffer({names.nodes, VkDeviceSize(capacity()) * kNodeBytes});
    graph.declareBuffer({names.counters, sizeof(Counters)});

    // Every list empty (the head kDeepNone), every counter 0. The whole atlas: the sort
    // and links passes walk every texel, also those the fragment pass does not draw.
    plugin::ClearPass(graph, io.local("clear"))
        .image(names.heads, {.uint32 = {0xFFFFFFFFu, 0, 0, 0}})
        .buffer(names.counters, 0)
        .dependsOn(io.lightState);

    graph.addPass(io.local("fragments"), graph::QueueKind::Graphics)
        .read(names.opaque, graph::Usage::DepthAttachment)
        .read(names.heads, graph::Usage::Storage)
        .write(names.heads, graph::Usage::Storage)
        .write(names.nodes, graph::Usage::Storage)
        .read(names.counters, graph::Usage::Storage)
        .write(names.counters, graph::Usage::Storage)
        .dependsOn(io.lightState)
        .execute([this, names](graph::PassContext& pass) { recordFragments(pass, names); });

    graph.addPass(io.local("sort"), graph::QueueKind::Compute)
        .read(names.heads, graph::Usage::Storage)
        .read(names.nodes, graph::Usage::Storage)
        .write(names.nodes, graph::Usage::Storage)
        .write(names.lengths, graph::Usage::Storage)
        .read(names.counters, graph::Usage::Storage)
        .write(names.counters, graph::Usage::Storage)
        .dependsOn(io.lightState)
        .execute([this, names](graph::PassContext& pass) {
            sort_.bind(pass.cmd());
            gpu::DescriptorPush()
                .storageImage("heads", pass.image(names.heads))
                .storageImage("lengths", pass.image(names.lengths))
                .storageBuffer("DeepNodes", pass.buffer(names.nodes))
                .storageBuffer("DeepCounters", pass.buffer(names.counters))
                .push(context_, pass.cmd(), sort_);
            const SortPush push{settings_.epsilon, capacity()};
            sort_.pushConstants(pass.cmd(), &push, sizeof(push));
            sort_.dispatchOver(pass.cmd(), pass.image(names.heads));
        });

    // Links only where the lookup follows them: PCF over the links (one tap, the brute
    // force and the first fragment walk no neighbour's list).
    if (usesLinks()) addLinksPass(graph, io, names, io.local("links"));

    const auto bind = [this, names](const graph::PassContext& pass, gpu::DescriptorPush& descriptors) {
        descriptors.storageImage("heads", pass.image(names.heads))
            .storageBuffer("shadowMapBuffer", shadowMap_.buffer())
            .storageBuffer("DeepNodes", pass.buffer(names.nodes));
        const float offset = settings_.biasMode == BiasMode::NormalOffset ? settings_.normalOffsetTexels : 0.0f;
        const VisibilityPush push{offset * float(settings_.pcfKernel), settings_.esmExponent};
        visibility_.pushConstants(pass.cmd(), &push, sizeof(push));
    };
    plugin::addVisibilityPass(graph, io, visibility_, bind)
        .read(names.heads, graph::Usage::Storage)
        .read(names.nodes, graph::Usage::Storage)
        .read(names.lengths, graph::Usage::Storage)
        .dependsOn(io.lightState)
        .dependsOn(io.cameraState);

    // The debug views, culled unless one of their images is requested.
    const auto bindDebug = [this, names](const graph::PassContext& pass, gpu::DescriptorPush& descriptors,
                                         const gpu::Pipeline& pipeline) {
        descriptors.storageImage("heads", pass.image(names.heads))
            .storageImage("lengths", pass.image(names.lengths))
            .storageBuffer("DeepNodes", pass.buffer(names.nodes))
            .storageBuffer("shadowMapBuffer", shadowMap_.buffer());
        pipeline.pushConstants(pass.cmd(), &settings_.debugDepth, sizeof(float));
    };
    debugViews_.addOverTexels(graph, io, io.local("debug_views"), kDebugImages, w, h, bindDebug)
        .read(names.heads, graph::Usage::Storage)
        .read(names.lengths, graph::Usage::Storage)
        .read(names.nodes, graph::Usage::Storage);

    // The frame's counters, for wantsRedraw() and the figures after the frame.
    graph.declareBuffer({names.lastCounters, sizeof(Counters), true});
    io.bindBuffer(names.lastCounters, counters_);
    graph.readBack(names.lastCounters);
    graph.addPass(io.local("counters_readback"), graph::QueueKind::Transfer)
        .read(names.counters, graph::Usage::TransferSrc)
        .write(names.lastCounters, graph::Usage::TransferDst)
        .dependsOn(io.lightState)
        .execute([names](graph::PassContext& pass) {
            const VkBufferCopy region{0, 0, sizeof(Counters)};
            vkCmdCopyBuffer(pass.cmd(), pass.buffer(names.counters).handle(), pass.buffer(names.lastCounters).handle(),
                            1, &region);
        });
}

} // namespace
} // namespace penumbra::deep

PENUMBRA_DEFINE_PLUGIN("deep", "1.0.0",
                       "deep shadow map: per-texel fragment lists, sorted into transmittance functions, truncated and "
                       "linked to their neighbours; translucent casters attenuate; PCF over linked lists or EDSM",
                       penumbra::deep::kParams, penumbra::deep::DeepShadow)
