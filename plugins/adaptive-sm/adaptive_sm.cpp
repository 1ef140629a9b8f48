// Adaptive shadow maps (Fernando, Fernandez, Bala, Greenberg 2001; Fernando's thesis
// 2002, ch. 2; README.md next to this file): the light view as a quadtree of fixed-size
// depth tiles in one atlas of exactly memory_mib MiB, refined where the eye sees shadow
// edges under-sampled, progressively, inside a per-frame time budget. One quadtree for a
// spot or directional light's view, six (render::ShadowMap's cube faces, from the light's
// centre) for point, rect and disk lights.
//
// Every frame (one draw of the render graph), in pass order:
//   tiles     (graphics)  the CPU step: last frame's analysis -> LRU and benefits ->
//                         the most profitable new nodes within refine_ms (a N + b each,
//                         calibrated at start-up), evicting when the atlas is full; the
//                         node table is uploaded and the new (and invalidated) tiles are
//                         drawn, each with its own cropped light view through
//                         render::Casters
//   ranges    (compute)   each new tile's min/max depth, then every node's subtree range
//   analyze   (compute)   1 in analyze_stride G-buffer pixels: used / edge / benefit
//                         counts per node and quadrant, read by the next frame's step
//   visibility (compute)  the query: walk to the finest node (depth culling), compare
//                         (PCF across tile borders by walking again)
//   debug_screen, debug_light: the debug views, culled unless requested
#include "tile_tree.h"

#include "penumbra/core/Error.h"
#include "penumbra/gpu/Barrier.h"
#include "penumbra/gpu/Context.h"
#include "penumbra/gpu/GpuTimer.h"
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/gpu/Resources.h"
#include "penumbra/graph/PassContext.h"
#include "penumbra/graph/RenderGraph.h"
#include "penumbra/plugin/ComputePipeline.h"
#include "penumbra/plugin/DebugViews.h"
#include "penumbra/plugin/GBuffer.h"
#include "penumbra/plugin/Plugin.h"
#include "penumbra/plugin/ShadowMapParams.h"
#include "penumbra/plugin/Technique.h"
#include "penumbra/plugin/VisibilityPass.h"
#include "penumbra/render/ShadowMap.h"

#include <fmt/format.h>
#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <iterator>
#include <numeric>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

namespace penumbra::adaptive_sm {
namespace {

using plugin::ParamType;

constexpr uint32_t kDebugLightTexels = 512;  // resident_tiles, tile_benefit: the light view's height
constexpr uint32_t kTileBytesPerTexel = 4;   // D32_SFLOAT
constexpr uint32_t kPageLevel = 6;           // the page table: 64² cells a face (asm_tree.glsl)

const plugin::ParamSpec kParams[] = {
    {"memory_mib", ParamType::Int, 16, 1, 1024, "MiB",
     "tile atlas: exactly this many MiB of tile_texels² D32 tiles (the thesis compares 16 MiB with a 2048² map)"},
    {"tile_texels", ParamType::Int, 128, 32, 512, "texels", "texels per side of every tile, a power of two"},
    {"base_level", ParamType::Int, 2, 0, 6, "",
     "levels 0 .. base_level are always resident (2: the thesis' 512² start with 128² tiles)"},
    {"max_level", ParamType::Int, 12, 0, kMaxLevels - 1, "",
     "deepest level: tile_texels * 2^max_level texels across the light view at most"},
    {"refine_ms", ParamType::Float, 20, 0, 1e5, "ms",
     "time budget per frame for new tiles, at the calibrated cost a N + b each; at least one tile a frame "
     "while any cell asks"},
    {"analyze_stride", ParamType::Int, 8, 1, 64, "",
     "one G-buffer pixel in this many is analyzed per frame, in a pattern that moves every frame (the thesis: 8)"},
    {"texels_per_pixel", ParamType::Float, 2, 0.125, 16, "",
     "refine while a shadow edge's texel is wider than 1 / texels_per_pixel eye pixels (2: Nyquist, as the thesis "
     "states it; 1: the thesis' test)"},
    {"min_benefit", ParamType::Int, 1, 1, 1e9, "pixels", "analyzed edge pixels a new tile must resolve at least"},
    {"settle_rounds", ParamType::Int, 8, 0, 15, "",
     "a frame is drawn again (at most this many times) while refinement still finds work, so a still image shows "
     "the refined map; 0: one refinement step per frame (a walkthrough, as the thesis measured)"},
    {"depth_culling", ParamType::Bool, 1, 0, 1, "",
     "stop a lookup at the first node whose subtree depth range decides it (exact; the thesis' min-max culling)"},
    plugin::kShadowDepthBiasParam,
    plugin::slopeBiasParam("slope-scaled depth bias factor (rasterizer, per tile: it follows each tile's texel "
                           "size), per texel of the filter's width"),
    plugin::kBiasClampParam,
    plugin::oddKernelParam("pcf_kernel", 1, 7,
                           "taps per side of a PCF box at the finest node's texel spacing, odd; taps past a tile read "
                           "its neighbour"),
};

struct Settings {
    uint32_t memoryMib = 16;
    uint32_t tile = 128;
    uint32_t baseLevel = 2;
    uint32_t maxLevel = 12;
    float refineMs = 20.0f;
    uint32_t analyzeStride = 8;
    float texelsPerPixel = 2.0f;
    uint32_t minBenefit = 1;
    uint32_t settleRounds = 8;
    bool depthCulling = true;
    render::ShadowDepthBias bias;
    uint32_t pcfKernel = 1;
};

Settings readSettings(const plugin::ParamValues& params)
{
    Settings s;
    s.pcfKernel = uint32_t(params.getInt("pcf_kernel"));
    s.memoryMib = uint32_t(params.getInt("memory_mib"));
    s.tile = uint32_t(params.getInt("tile_texels"));
    if ((s.tile & (s.tile - 1)) != 0)
        throw ConfigError(fmt::format("adaptive-sm: tile_texels: {} is not a power of two (32, 64, 128, 256 or 512)",
                                      s.tile));
    s.baseLevel = uint32_t(params.getInt("base_level"));
    s.maxLevel = uint32_t(params.getInt("max_level"));
    if (s.maxLevel < s.baseLevel)
        throw ConfigError(fmt::format("adaptive-sm: max_level: {} is below base_level {}", s.maxLevel, s.baseLevel));
    s.refineMs = params.getFloat("refine_ms");
    s.analyzeStride = uint32_t(params.getInt("analyze_stride"));
    s.texelsPerPixel = params.getFloat("texels_per_pixel");
    s.minBenefit = uint32_t(params.getInt("min_benefit"));
    s.settleRounds = uint32_t(params.getInt("settle_rounds"));
    s.depthCulling = params.getBool("depth_culling");
    s.bias = {params.getFloat("depth_bias"), params.getFloat("slope_bias") * float(s.pcfKernel),
              params.getFloat("bias_clamp")};
    return s;
}

// The atlas's slots: exactly memory_mib MiB of tiles, laid out as the divisor of the slot
// count nearest its square root, so the image holds no texel beyond the budget.
struct AtlasLayout {
    uint32_t slots = 0;
    uint32_t columns = 0;
    uint32_t rows = 0;
};
AtlasLayout atlasLayout(const Settings& s, uint32_t maxImageTexels)
{
    const uint64_t tileBytes = uint64_t(s.tile) * s.tile * kTileBytesPerTexel;
    const uint64_t slots = (uint64_t(s.memoryMib) << 20) / tileBytes;  // exact: tile² * 4 divides 1 MiB for tile <= 512
    AtlasLayout layout;
    layout.slots = uint32_t(slots);
    for (uint64_t c = uint64_t(std::sqrt(double(slots))); c >= 1; --c)
        if (slots % c == 0) {
            layout.rows = uint32_t(c);
            layout.columns = uint32_t(slots / c);
            break;
        }
    if (uint64_t(layout.columns) * s.tile > maxImageTexels || uint64_t(layout.rows) * s.tile > maxImageTexels)
        throw ConfigError(fmt::format("adaptive-sm: memory_mib: {} MiB of {}² tiles is an atlas of {} x {} tiles, "
                                      "wider than this device's largest image ({} texels); use fewer MiB or larger "
                                      "tiles",
                                      s.memoryMib, s.tile, layout.columns, layout.rows, maxImageTexels));
    return layout;
}

// The crop of the light's clip space to the cell (level, x, y) of the uv square: the cell
// fills the tile's viewport. uv = ndc / 2 + 1/2, so the cell's ndc centre is
// 2 (x + 1/2) / 2^L - 1 and its scale 2^L; applied in clip space (w kept).
glm::mat4 cellCrop(uint32_t level, uint32_t x, uint32_t y)
{
    const float scale = std::ldexp(1.0f, int(level));
    const float cx = 2.0f * (float(x) + 0.5f) / scale - 1.0f, cy = 2.0f * (float(y) + 0.5f) / scale - 1.0f;
    glm::mat4 crop(1.0f);
    crop[0][0] = scale;
    crop[1][1] = scale;
    crop[3][0] = -scale * cx;
    crop[3][1] = -scale * cy;
    return crop;
}

struct AnalyzePush {
    uint32_t frame;
    uint32_t stride;
    float texelsPerPixel;
};

class AdaptiveShadowMap final : public plugin::Technique {
public:
    explicit AdaptiveShadowMap(const plugin::TechniqueSetup& setup);
    AdaptiveShadowMap(const AdaptiveShadowMap&) = delete;
    AdaptiveShadowMap& operator=(const AdaptiveShadowMap&) = delete;

    void update(const scene::Light& light, const scene::Aabb& sceneBounds) override;
    void instancesMoved(std::span<const uint32_t> instances) override;
    void registerPasses(graph::RenderGraph& graph, const plugin::LightPassIo& io) override;
    std::vector<plugin::TechniqueFigure> figures() const override;
    bool wantsRedraw() override;

private:
    struct Names {
        std::string atlas, ranges, analysis;
    };
    void calibrateTileCost(const plugin::TechniqueSetup& setup);
    void readLastAnalysis();
    void refineAndRecordTiles(const graph::PassContext& pass, const Names& names);
    void recordRanges(const graph::PassContext& pass, const Names& names);
    std::vector<gpu::ShaderDefine> treeDefines() const;
    double tileCostMs() const { return costPerTexelMs_ * double(settings_.tile) * settings_.tile + costPerTileMs_; }

    gpu::Context& context_;
    const render::Casters& casters_;
    const scene::Scene& scene_;
    const uint32_t width_, height_;  // the G-buffer's
    const Settings settings_;
    render::ShadowMap shadowMap_;  // the light view's frustum (one face) and its ShadowMapData
    AtlasLayout layout_;
    TileTree tree_;
    gpu::Image atlas_;        // imported: the tiles, kept between frames (DEPTH_READ_ONLY_OPTIMAL)
    gpu::Buffer ranges_;      // imported: vec4 per slot (own min, max; subtree min, max)
    gpu::Buffer analysis_;    // imported, host-visible: NodeAnalysis per slot, written by analyze
    gpu::Buffer nodeTable_;   // host-visible: GpuNode per slot, written by the CPU step
    gpu::Buffer tileList_;    // host-visible: the slots drawn this frame
    gpu::Buffer order_;       // host-visible: levelStart[kMaxLevels + 1], then the bottom-up slots
    gpu::Buffer pageTable_;   // host-visible: the walks' starting nodes (TileTree::pageTable)
    uint32_t pageLevel_ = 0;
    std::vector<int32_t> pages_;
    uint64_t uploadedVersion_ = ~uint64_t(0);  // the tree version the host tables hold
    bool treeChanged_ = true;                   // this draw's step changed the tree
    gpu::Pipeline visibility_;
    gpu::Pipeline analyze_;
    gpu::Pipeline tileRange_;
    gpu::Pipeline subtreeRange_;
    // The debug views (debug.comp DEBUG_VIEW 0 and 1), compiled when first requested.
    std::optional<plugin::DebugViewPass> debugScreen_;
    std::optional<plugin::DebugViewPass> debugLight_;
    gpu::Sampler depthSampler_;
    double costPerTexelMs_ = 0.0;  // a
    double costPerTileMs_ = 0.0;   // b
    std::vector<glm::mat4> lightViewProj_;  // per face, as the tiles were drawn
    std::vector<scene::Aabb> instanceBounds_;  // as the tiles last saw them

    // The frame's state.
    uint64_t frame_ = 0;          // draws so far (the analysis pattern moves with it)
    bool analysisPending_ = false;  // the last draw analyzed; its counts are not read yet
    bool resetPending_ = true;    // the tree was reset: the counts refer to old nodes
    std::vector<uint32_t> drawnThisFrame_;  // this draw's tiles
    uint32_t settleRound_ = 0;
    bool frameStarts_ = true;  // the next draw is a frame's first (not a settling redraw)
    uint32_t invalidatedSinceDraw_ = 0;
    uint64_t resets_ = 0;
    // Figures of the last frame, over all its draws.
    struct FrameFigures {
        uint32_t draws = 0;
        uint32_t drawn = 0;
        uint32_t created = 0;
        uint32_t invalidated = 0;
        uint32_t evicted = 0;
        uint32_t asking = 0;    // the last draw's step
        uint32_t deferred = 0;  // the last draw's step
        double stepCpuMs = 0.0;
    } last_;
};

AdaptiveShadowMap::AdaptiveShadowMap(const plugin::TechniqueSetup& setup)
    : context_(setup.context),
      casters_(setup.casters),
      scene_(setup.scene),
      width_(std::max(setup.width, 1u)),
      height_(std::max(setup.height, 1u)),
      settings_(readSettings(setup.params)),
      shadowMap_(setup, settings_.tile, "adaptive-sm"),
      layout_(atlasLayout(settings_, context_.properties().limits.maxImageDimension2D)),
      tree_([&] {
          try {
              return TileTree(layout_.slots, settings_.baseLevel, settings_.maxLevel, shadowMap_.faceCount());
          } catch (const std::invalid_argument& e) {
              throw ConfigError(fmt::format("adaptive-sm: base_level: {} MiB of {}² tiles: {}", settings_.memoryMib,
                                            settings_.tile, e.what()));
          }
      }())
{
    // Tiles persist across frames, so their casters must not depend on this frame's
    // camera: every caster in a tile's frustum that light-space culling keeps (the
    // receiver mask covers the whole view: no receiver-dependent culling).
    shadowMap_.setFootprint(render::CasterView::kWholeView);
    for (const render::LightFrustum& f : shadowMap_.frusta()) lightViewProj_.push_back(f.viewProj);

    atlas_ = gpu::Image(context_, {layout_.columns * settings_.tile, layout_.rows * settings_.tile,
                                   render::kShadowDepthFormat,
                                   VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT |
                                       VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                                   setup.local("atlas")});
    context_.submitAndWait([&](VkCommandBuffer cmd) {
        gpu::transition(cmd, atlas_, gpu::access::kUndefined, gpu::access::kComputeSampledDepth);
    });
    const VkBufferUsageFlags storage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    ranges_ = gpu::Buffer(context_, sizeof(glm::vec4) * layout_.slots, storage, false, setup.local("ranges"));
    analysis_ = gpu::Buffer(context_, sizeof(NodeAnalysis) * layout_.slots, storage, true, setup.local("analysis"));
    std::memset(analysis_.mapped(), 0, analysis_.size());
    nodeTable_ = gpu::Buffer(context_, sizeof(GpuNode) * layout_.slots, storage, true, setup.local("nodes"));
    tileList_ = gpu::Buffer(context_, sizeof(uint32_t) * layout_.slots, storage, true, setup.local("tile_list"));
    order_ = gpu::Buffer(context_, sizeof(uint32_t) * (kMaxLevels + 1 + layout_.slots), storage, true, setup.local("order"));
    pageLevel_ = std::min(settings_.maxLevel, kPageLevel);
    pageTable_ = gpu::Buffer(context_, sizeof(int32_t) * shadowMap_.faceCount() << (2 * pageLevel_), storage, true,
                             setup.local("pages"));
    depthSampler_ = render::createShadowDepthSampler(context_);
    instanceBounds_.reserve(scene_.instances.size());
    for (const scene::Instance& instance : scene_.instances) instanceBounds_.push_back(instance.worldBounds);

    std::vector<gpu::ShaderDefine> tree = treeDefines();
    std::ranges::copy(shadowMap_.shaderDefines(), std::back_inserter(tree));
    std::vector<gpu::ShaderDefine> query = tree;
    query.push_back({"PCF_KERNEL", std::to_string(settings_.pcfKernel)});
    query.push_back({"ASM_DEPTH_CULLING", settings_.depthCulling ? "1" : "0"});
    visibility_ = plugin::createComputePipeline(setup, "visibility", "visibility.comp", query);
    analyze_ = plugin::createComputePipeline(setup, "analyze", "analyze.comp", tree, sizeof(AnalyzePush));
    tileRange_ = plugin::createComputePipeline(setup, "tile_range", "tile_range.comp", treeDefines());
    subtreeRange_ = plugin::createComputePipeline(setup, "subtree_range", "subtree_range.comp", treeDefines());
    std::vector<gpu::ShaderDefine> screen = tree, light = tree;
    screen.push_back({"DEBUG_VIEW", "0"});
    light.push_back({"DEBUG_VIEW", "1"});
    debugScreen_.emplace(setup, plugin::computePipelineDesc(setup, "debug_screen", "debug.comp", screen));
    debugLight_.emplace(setup, plugin::computePipelineDesc(setup, "debug_light", "debug.comp", light));
    calibrateTileCost(setup);
}

std::vector<gpu::ShaderDefine> AdaptiveShadowMap::treeDefines() const
{
    return {{"ASM_TILE", std::to_string(settings_.tile)},
            {"ASM_ATLAS_COLUMNS", std::to_string(layout_.columns)},
            {"ASM_MAX_LEVEL", std::to_string(settings_.maxLevel)},
            {"ASM_PAGE_LEVEL", std::to_string(pageLevel_)}};
}

// The thesis' hardware calibration: the cost of a tile is a N + b (N its texels), a the
// per-texel rasterizer cost (clear, depth test and write) and b the per-tile overhead
// (the render pass, the state). Measured once with GPU timestamps: tiles of three sizes,
// each cleared and covered by one triangle, five times each; a and b by least squares
// over the medians, clamped at 0.
void AdaptiveShadowMap::calibrateTileCost(const plugin::TechniqueSetup& setup)
{
    gpu::GraphicsPipelineDesc d;
    d.name = setup.local("calibrate");
    d.vertexShader = "calibrate.vert";
    d.depthFormat = render::kShadowDepthFormat;
    d.cullMode = VK_CULL_MODE_NONE;
    const gpu::Pipeline pipeline(context_, setup.shaders, d);
    const uint32_t largest = settings_.tile;
    const gpu::Image target(context_, {largest, largest, render::kShadowDepthFormat,
                                       VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT, d.name + ".target"});
    const std::array<uint32_t, 3> sizes{std::max(8u, largest / 4), std::max(8u, largest / 2), largest};
    constexpr uint32_t kRepeats = 5;
    gpu::GpuTimer timer(context_, uint32_t(sizes.size()) * kRepeats);
    context_.submitAndWait([&](VkCommandBuffer cmd) {
        timer.beginFrame(cmd);
        gpu::transition(cmd, target, gpu::access::kUndefined, gpu::access::kDepthAttachment);
        for (uint32_t size : sizes)
            for (uint32_t r = 0; r < kRepeats; ++r) {
                const uint32_t scope = timer.beginScope(cmd, std::to_string(size));
                VkRenderingAttachmentInfo depth{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
                depth.imageView = target.view();
                depth.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
                depth.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
                depth.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
                VkRenderingInfo info{VK_STRUCTURE_TYPE_RENDERING_INFO};
                info.renderArea = {{0, 0}, {size, size}};
                info.layerCount = 1;
                info.pDepthAttachment = &depth;
                vkCmdBeginRendering(cmd, &info);
                const VkViewport viewport{0.0f, 0.0f, float(size), float(size), 0.0f, 1.0f};
                vkCmdSetViewport(cmd, 0, 1, &viewport);
                vkCmdSetScissor(cmd, 0, 1, &info.renderArea);
                pipeline.bind(cmd);
                vkCmdDraw(cmd, 3, 1, 0, 0);
                vkCmdEndRendering(cmd);
                timer.endScope(cmd, scope);
            }
    });
    const std::vector<gpu::ScopeTime> times = timer.collect();
    std::vector<double> n, t;
    for (size_t i = 0; i < sizes.size(); ++i) {
        std::vector<double> samples;
        for (uint32_t r = 0; r < kRepeats && i * kRepeats + r < times.size(); ++r)
            samples.push_back(times[i * kRepeats + r].gpuMs);
        if (samples.empty()) continue;
        std::ranges::nth_element(samples, samples.begin() + ptrdiff_t(samples.size() / 2));
        n.push_back(double(sizes[i]) * sizes[i]);
        t.push_back(samples[samples.size() / 2]);
    }
    if (n.size() < 2) return;  // no timestamps: no budget limit (refine takes every candidate)
    const double meanN = std::accumulate(n.begin(), n.end(), 0.0) / double(n.size());
    const double meanT = std::accumulate(t.begin(), t.end(), 0.0) / double(t.size());
    double sxy = 0.0, sxx = 0.0;
    for (size_t i = 0; i < n.size(); ++i) {
        sxy += (n[i] - meanN) * (t[i] - meanT);
        sxx += (n[i] - meanN) * (n[i] - meanN);
    }
    costPerTexelMs_ = sxx > 0.0 ? std::max(sxy / sxx, 0.0) : 0.0;
    costPerTileMs_ = std::max(meanT - costPerTexelMs_ * meanN, 0.0);
    if (!std::isfinite(costPerTexelMs_) || !std::isfinite(costPerTileMs_)) costPerTexelMs_ = costPerTileMs_ = 0.0;
}

void AdaptiveShadowMap::update(const scene::Light& light, const scene::Aabb& sceneBounds)
{
    shadowMap_.update(light, sceneBounds);
    // Every tile is a crop of its face's view: a new view (the light moved, or shadow
    // focusing refitted it) makes them all stale.
    std::vector<glm::mat4> viewProj;
    for (const render::LightFrustum& f : shadowMap_.frusta()) viewProj.push_back(f.viewProj);
    if (viewProj != lightViewProj_) {
        lightViewProj_ = std::move(viewProj);
        tree_.reset();
        ++resets_;
        resetPending_ = true;
    }
}

// A moved caster changes the depths only where it was and where it is now, as the light
// sees them: the tiles over those two boxes' projections are drawn again, face by face.
void AdaptiveShadowMap::instancesMoved(std::span<const uint32_t> instances)
{
    // The uv bounds of `box` in face `face`, grown into lo / hi; a box reaching behind the
    // face's plane covers all of it.
    const auto project = [&](uint32_t face, const scene::Aabb& box, glm::vec2& lo, glm::vec2& hi) {
        for (int corner = 0; corner < 8; ++corner) {
            const glm::vec3 p((corner & 1) ? box.max.x : box.min.x, (corner & 2) ? box.max.y : box.min.y,
                              (corner & 4) ? box.max.z : box.min.z);
            const glm::vec4 clip = lightViewProj_[face] * glm::vec4(p, 1.0f);
            if (!(clip.w > 0.0f)) {
                lo = glm::vec2(0.0f);
                hi = glm::vec2(1.0f);
                return;
            }
            const glm::vec2 uv = glm::vec2(clip) / clip.w * 0.5f + 0.5f;
            lo = glm::min(lo, uv);
            hi = glm::max(hi, uv);
        }
    };
    for (uint32_t i : instances) {
        if (i >= scene_.instances.size() || i >= instanceBounds_.size()) continue;
        const scene::Aabb& was = instanceBounds_[i];
        const scene::Aabb& now = scene_.instances[i].worldBounds;
        for (uint32_t face = 0; face < lightViewProj_.size(); ++face) {
            glm::vec2 lo(1e30f), hi(-1e30f);
            if (was.min.x <= was.max.x) project(face, was, lo, hi);
            if (now.min.x <= now.max.x) project(face, now, lo, hi);
            // Outside the face (or NaN): nothing of it to draw again.
            if (!(lo.x <= 1.0f && lo.y <= 1.0f && hi.x >= 0.0f && hi.y >= 0.0f)) continue;
            invalidatedSinceDraw_ += tree_.invalidate(face, lo.x, lo.y, hi.x, hi.y);
        }
        instanceBounds_[i] = now;
    }
}

void AdaptiveShadowMap::readLastAnalysis()
{
    if (!analysisPending_) return;
    analysisPending_ = false;
    if (resetPending_) return;  // counted for nodes that no longer exist
    const auto* counts = static_cast<const NodeAnalysis*>(analysis_.mapped());
    tree_.recordAnalysis({counts, layout_.slots}, frame_);
}

// The CPU step of one draw (the previous draw has finished: the executor waits), then the
// draws of its tiles. Runs as the tile pass records.
void AdaptiveShadowMap::refineAndRecordTiles(const graph::PassContext& pass, const Names& names)
{
    const auto start = std::chrono::steady_clock::now();
    if (frameStarts_) {
        last_ = {};
        frameStarts_ = false;
    }
    readLastAnalysis();
    ++frame_;
    resetPending_ = false;
    const RefineStep step = tree_.refine({settings_.refineMs, tileCostMs(), settings_.minBenefit});
    drawnThisFrame_ = tree_.takePending();
    ++last_.draws;
    last_.drawn += uint32_t(drawnThisFrame_.size());
    last_.created += uint32_t(step.created.size());
    last_.invalidated += invalidatedSinceDraw_;
    invalidatedSinceDraw_ = 0;
    last_.evicted += step.evicted;
    last_.asking = step.candidates;
    last_.deferred = step.deferred;
    std::ranges::sort(drawnThisFrame_);

    // The tile list and cleared analysis counts every draw; the tables derived from the
    // tree (nodes, bottom-up order, pages) only when it changed.
    if (!drawnThisFrame_.empty())  // data() may be null then, which memcpy must not get
        std::memcpy(tileList_.mapped(), drawnThisFrame_.data(), sizeof(uint32_t) * drawnThisFrame_.size());
    std::memset(analysis_.mapped(), 0, analysis_.size());
    treeChanged_ = tree_.version() != uploadedVersion_;
    if (treeChanged_) {
        std::memcpy(nodeTable_.mapped(), tree_.table().data(), sizeof(GpuNode) * tree_.table().size());
        std::vector<uint32_t> order;
        std::array<uint32_t, kMaxLevels + 1> levelStart{};
        tree_.bottomUpOrder(order, levelStart);
        auto* orderOut = static_cast<uint32_t*>(order_.mapped());
        std::memcpy(orderOut, levelStart.data(), sizeof(levelStart));
        std::memcpy(orderOut + levelStart.size(), order.data(), sizeof(uint32_t) * order.size());
        tree_.pageTable(pageLevel_, pages_);
        std::memcpy(pageTable_.mapped(), pages_.data(), sizeof(int32_t) * pages_.size());
        uploadedVersion_ = tree_.version();
    }

    // Each tile: the light view cropped to its cell, drawn into its slot (the other
    // slots keep their tiles).
    std::vector<render::LightFrustum> frusta;
    frusta.reserve(drawnThisFrame_.size());
    for (uint32_t slot : drawnThisFrame_) {
        const GpuNode& n = tree_.table()[slot];
        const render::LightFrustum& light = shadowMap_.frusta()[n.face];
        render::LightFrustum f = light;
        f.proj = cellCrop(n.level, n.x, n.y) * light.proj;
        f.viewProj = cellCrop(n.level, n.x, n.y) * light.viewProj;
        frusta.push_back(f);
    }
    std::vector<render::ShadowMapPlacement> placements;
    placements.reserve(drawnThisFrame_.size());
    for (size_t i = 0; i < drawnThisFrame_.size(); ++i) {
        const uint32_t slot = drawnThisFrame_[i];
        placements.push_back({{&frusta[i], 1},
                              {int32_t((slot % layout_.columns) * settings_.tile), int32_t((slot / layout_.columns) * settings_.tile)},
                              slot});
    }
    shadowMap_.recordDepthMaps(pass, names.atlas, settings_.bias, placements, render::MapClear::EachFace);
    last_.stepCpuMs += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

void AdaptiveShadowMap::recordRanges(const graph::PassContext& pass, const Names& names)
{
    const VkCommandBuffer cmd = pass.cmd();
    if (!drawnThisFrame_.empty()) {
        tileRange_.bind(cmd);
        gpu::DescriptorPush()
            .sampledImage("atlas", pass.image(names.atlas), depthSampler_, pass.layout(names.atlas))
            .storageBuffer("AsmNodes", nodeTable_)
            .storageBuffer("AsmRanges", pass.buffer(names.ranges))
            .storageBuffer("AsmTileList", tileList_)
            .push(context_, cmd, tileRange_);
        vkCmdDispatch(cmd, uint32_t(drawnThisFrame_.size()), 1, 1);
        gpu::memoryBarrier(cmd, gpu::access::kComputeStorageWrite, gpu::access::kComputeStorageReadWrite);
    }
    // Subtree ranges change with new tiles and with evictions; otherwise they stand.
    if (drawnThisFrame_.empty() && !treeChanged_) return;
    subtreeRange_.bind(cmd);
    gpu::DescriptorPush()
        .storageBuffer("AsmNodes", nodeTable_)
        .storageBuffer("AsmRanges", pass.buffer(names.ranges))
        .storageBuffer("AsmOrder", order_)
        .push(context_, cmd, subtreeRange_);
    vkCmdDispatch(cmd, 1, 1, 1);
}

void AdaptiveShadowMap::registerPasses(graph::RenderGraph& graph, const plugin::LightPassIo& io)
{
    const Names names{io.local("atlas"), io.local("ranges"), io.local("analysis")};
    graph.declareImage({names.atlas, atlas_.desc().width, atlas_.desc().height, render::kShadowDepthFormat, true,
                        VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL});
    graph.declareBuffer({names.ranges, ranges_.size(), true});
    graph.declareBuffer({names.analysis, analysis_.size(), true});
    io.bindImage(names.atlas, atlas_);
    io.bindBuffer(names.ranges, ranges_);
    io.bindBuffer(names.analysis, analysis_);

    graph.addPass(io.local("tiles"), graph::QueueKind::Graphics)
        .write(names.atlas, graph::Usage::DepthAttachment)
        .execute([this, names](graph::PassContext& pass) { refineAndRecordTiles(pass, names); });

    graph.addPass(io.local("ranges"), graph::QueueKind::Compute)
        .read(names.atlas, graph::Usage::Sampled)
        .read(names.ranges, graph::Usage::Storage)
        .write(names.ranges, graph::Usage::Storage)
        .execute([this, names](graph::PassContext& pass) { recordRanges(pass, names); });

    // The analysis is read back by the next draw's CPU step.
    graph.readBack(names.analysis);
    graph::PassBuilder analyze = graph.addPass(io.local("analyze"), graph::QueueKind::Compute);
    plugin::readGBuffer(analyze, io.gbuffer);
    analyze.read(names.atlas, graph::Usage::Sampled)
        .write(names.analysis, graph::Usage::Storage)
        .execute([this, names, io](graph::PassContext& pass) {
            const VkCommandBuffer cmd = pass.cmd();
            analyze_.bind(cmd);
            gpu::DescriptorPush descriptors;
            plugin::bindGBuffer(pass, io.gbuffer, descriptors);
            descriptors.sampledImage("atlas", pass.image(names.atlas), depthSampler_, pass.layout(names.atlas))
                .storageBuffer("shadowMapBuffer", shadowMap_.buffer())
                .storageBuffer("AsmNodes", nodeTable_)
                .storageBuffer("AsmPages", pageTable_)
                .storageBuffer("AsmAnalysis", pass.buffer(names.analysis))
                .push(context_, cmd, analyze_);
            const AnalyzePush push{uint32_t(frame_), settings_.analyzeStride, settings_.texelsPerPixel};
            analyze_.pushConstants(cmd, &push, sizeof(push));
            // One invocation per analyzed pixel (analyze.comp maps it to its pixel).
            analyze_.dispatchOver(cmd, (width_ + settings_.analyzeStride - 1) / settings_.analyzeStride, height_);
            analysisPending_ = true;
        });

    const auto bind = [this, names](const graph::PassContext& pass, gpu::DescriptorPush& descriptors) {
        descriptors.sampledImage("atlas", pass.image(names.atlas), depthSampler_, pass.layout(names.atlas))
            .storageBuffer("shadowMapBuffer", shadowMap_.buffer())
            .storageBuffer("AsmNodes", nodeTable_)
            .storageBuffer("AsmPages", pageTable_)
            .storageBuffer("AsmRanges", pass.buffer(names.ranges));
    };
    plugin::addVisibilityPass(graph, io, visibility_, bind)
        .read(names.atlas, graph::Usage::Sampled)
        .read(names.ranges, graph::Usage::Storage);

    // Debug views: the screen's tile levels, and the light view's resident tiles and
    // benefits (after this frame's analysis), culled unless requested.
    constexpr plugin::DebugImage kScreen[] = {{"tile_level", "tileLevel"}};
    constexpr plugin::DebugImage kLight[] = {{"resident_tiles", "residentTiles"}, {"tile_benefit", "tileBenefit"}};
    const auto bindTree = [this](const graph::PassContext&, gpu::DescriptorPush& descriptors, const gpu::Pipeline&) {
        descriptors.storageBuffer("shadowMapBuffer", shadowMap_.buffer())
            .storageBuffer("AsmNodes", nodeTable_)
            .storageBuffer("AsmPages", pageTable_);
    };
    debugScreen_->addOverGBuffer(graph, io, io.local("debug_screen"), kScreen, bindTree)
        .read(names.atlas, graph::Usage::Sampled);
    // One face at 512², or the six cube faces at 256² each in 3 x 2 cells.
    const bool cube = shadowMap_.faceCount() > 1;
    const uint32_t lightWidth = cube ? 3 * kDebugLightTexels / 2 : kDebugLightTexels;
    const auto bindAnalysis = [bindTree, names](const graph::PassContext& pass, gpu::DescriptorPush& descriptors,
                                                const gpu::Pipeline& pipeline) {
        bindTree(pass, descriptors, pipeline);
        descriptors.storageBuffer("AsmAnalysis", pass.buffer(names.analysis));
    };
    debugLight_->addOverTexels(graph, io, io.local("debug_light"), kLight, lightWidth, kDebugLightTexels, bindAnalysis)
        .read(names.analysis, graph::Usage::Storage);
}

bool AdaptiveShadowMap::wantsRedraw()
{
    readLastAnalysis();
    if (settleRound_ < settings_.settleRounds && tree_.wantsMore(settings_.minBenefit)) {
        ++settleRound_;
        return true;
    }
    settleRound_ = 0;
    frameStarts_ = true;
    return false;
}

std::vector<plugin::TechniqueFigure> AdaptiveShadowMap::figures() const
{
    const double mib = 1.0 / double(1u << 20);
    const double tileBytes = double(settings_.tile) * settings_.tile * kTileBytesPerTexel;
    const double tableBytes = double(nodeTable_.size() + ranges_.size() + analysis_.size() + tileList_.size() +
                                     order_.size() + pageTable_.size());
    return {
        {"resident_tiles", double(tree_.resident()), "tiles"},
        {"atlas_slots", double(layout_.slots), "tiles"},
        {"tile_memory_mib", double(tree_.resident()) * tileBytes * mib, "MiB"},
        {"atlas_mib", double(layout_.slots) * tileBytes * mib, "MiB"},
        {"table_mib", tableBytes * mib, "MiB"},
        {"refine_steps", double(last_.draws), ""},
        {"tiles_drawn", double(last_.drawn), "tiles"},
        {"tiles_created", double(last_.created), "tiles"},
        {"tiles_invalidated", double(last_.invalidated), "tiles"},
        {"evictions", double(last_.evicted), "tiles"},
        {"evictions_total", double(tree_.totalEvictions()), "tiles"},
        {"cells_asking", double(last_.asking), ""},
        {"cells_deferred", double(last_.deferred), ""},
        {"deepest_level", double(tree_.deepestLevel()), ""},
        {"effective_resolution", double(settings_.tile) * std::ldexp(1.0, int(tree_.deepestLevel())), "texels"},
        {"tile_cost_a", costPerTexelMs_ * 1e6, "ns/texel"},
        {"tile_cost_b", costPerTileMs_, "ms/tile"},
        {"tile_step_cpu_ms", last_.stepCpuMs, "ms"},
        {"view_resets", double(resets_), ""},
    };
}

} // namespace
} // namespace penumbra::adaptive_sm

PENUMBRA_DEFINE_PLUGIN("adaptive-sm", "1.0.0",
                       "adaptive shadow map: a view-driven quadtree of shadow-map tiles in a fixed memory budget, "
                       "refined by cost and benefit, progressive, with LRU eviction (Fernando et al. 2001)",
                       penumbra::adaptive_sm::kParams, penumbra::adaptive_sm::AdaptiveShadowMap)
