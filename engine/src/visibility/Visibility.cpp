#include "visibility/Visibility.h"

#include "penumbra/core/Error.h"
#include "penumbra/gpu/Barrier.h"
#include "penumbra/gpu/Check.h"
#include "penumbra/gpu/Context.h"
#include "penumbra/gpu/ShaderCompiler.h"

#include <glm/gtc/matrix_inverse.hpp>

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>

namespace penumbra::visibility {
namespace {

constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;
constexpr VkFormat kMaskFormat = VK_FORMAT_R8_UNORM;
// Receiver depths (engine/receiver_scatter.comp RECEIVER_DEPTH): the bits of a
// non-negative float, all ones where no receiver reads the texel.
constexpr VkFormat kReceiverDepthFormat = VK_FORMAT_R32_UINT;

// Texels added to every view's footprint in the mask: the technique's lookup texel may
// round differently from the mask's (1), and receiver bias (normal offset, receiver
// plane) moves the lookup by up to about a texel (1).
constexpr float kMaskSafetyTexels = 2.0f;
// The receiver mask is kept at most this many texels per side: each mask texel stands for
// a block of the view's texels and is set when any texel of the block is. The queries
// still rasterise at the view's own resolution (so coverage is the technique's), and only
// their mask lookup is coarse: conservative, and it keeps the dilation's cost (serial
// sweeps per row and column) low. Measured on config/city-street.json (hard, 2048
// texels; `penumbra render --culling receiver-mask --stats`): 256 drew 32,930 caster
// triangles with 25 ms of masks, 512 drew 26,738 with 28 ms, 1024 25,810 with 40 ms,
// 2048 23,458 with 97 ms.
constexpr uint32_t kMaxMaskTexels = 512;
// lavapipe (PLATFORM.md): in a long run of queries inside one rendering instance about
// one in 1,000 over-counts; ending and resuming rendering every few hundred keeps them
// exact. (An over-count only costs culling; it is never wrong.)
constexpr uint32_t kQueriesPerRendering = 256;
// CHC++ multi-queries: nodes invisible for this many frames in a row are queried in
// batches of up to kMultiQueryBatch; a batch that finds samples is queried node by node
// in the next round.
constexpr uint16_t kMultiQueryAfterFrames = 2;
constexpr uint32_t kMultiQueryBatch = 8;
// A leaf drawn without waiting (visible last frame) whose draw finds no sample is drawn
// so again for up to this many frames before its box is queried again. A box can show
// around geometry that never counts (a lit receiver that shadows nothing: its box takes
// no bias), and without this such a leaf would alternate between a draw and a chain of
// query rounds every other frame.
constexpr uint8_t kEmptyDrawFrames = 8;
// Inner nodes whose projection covers more than this fraction of the view are opened
// without a query.
constexpr float kOpenWithoutQueryFraction = 1.0f / 64.0f;
// A light view whose last full culling kept more than this fraction of the instances in
// its frustum takes its frustum's instances, for up to kRecheckFrames frames.
constexpr double kFallbackKeptFraction = 0.4;
constexpr uint32_t kRecheckFrames = 8;

double msSince(std::chrono::steady_clock::time_point start)
{
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

struct GpuBox {
    glm::vec4 lo;
    glm::vec4 hi;
};

struct ScatterPush {  // receiver_scatter.comp Push
    glm::mat4 lightViewProj;
    int32_t maskBlock;
    int32_t resolution;
};

struct CulledQueryPush {  // culling_mask.frag / occlusion_box.vert Push
    glm::mat4 viewProj;
    int32_t maskBlock;
    int32_t ownDepth;
    float biasSlope;
    float biasClamp;
};

struct CameraData {  // receiver_scatter.comp Camera
    glm::mat4 inverseViewProj;
    glm::vec4 size;
    glm::vec4 eye;
};

bool outside(const scene::Frustum& f, const scene::Aabb& box)
{
    for (uint32_t i = 0; i < f.planeCount; ++i) {
        const glm::vec4& p = f.planes[i];
        const glm::vec3 far(p.x >= 0 ? box.max.x : box.min.x, p.y >= 0 ? box.max.y : box.min.y,
                            p.z >= 0 ? box.max.z : box.min.z);
        if (glm::dot(glm::vec3(p), far) + p.w < 0.0f) return true;
    }
    return false;
}

// The view texels a box's projection can cover (with a texel of margin for the proxy's
// inflation and rounding), or nothing when any part of the box lies in front of the
// near plane (or behind the eye): its proxy would be clipped there, and a query could
// miss geometry inside it that the view does see, so such a node is treated as visible
// without a query.
struct TexelRect {
    glm::vec2 lo, hi;
    float area() const { return std::max(hi.x - lo.x, 0.0f) * std::max(hi.y - lo.y, 0.0f); }
};

std::optional<TexelRect> projectedRect(const glm::mat4& viewProj, const scene::Aabb& box, uint32_t width,
                                       uint32_t height)
{
    glm::vec2 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
    for (int c = 0; c < 8; ++c) {
        const glm::vec4 clip = viewProj * glm::vec4(box.corner(c), 1.0f);
        if (!(clip.w > 0.0f) || clip.z > clip.w) return std::nullopt;
        const glm::vec2 p = (glm::vec2(clip) / clip.w * 0.5f + 0.5f) * glm::vec2(float(width), float(height));
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
    }
    // Clamped to the view: only covered texels cost, and a box larger than the view
    // still covers it whole.
    const glm::vec2 size{float(width), float(height)};
    return TexelRect{glm::clamp(lo - 1.0f, glm::vec2(-1.0f), size), glm::clamp(hi + 1.0f, glm::vec2(-1.0f), size)};
}

// A box a little larger than `box`, so that no rasterization tie rule lets geometry on
// its faces produce a sample that the box does not.
GpuBox inflated(const scene::Aabb& box)
{
    const glm::vec3 extent = box.max - box.min;
    const float scale = std::max({extent.x, extent.y, extent.z, glm::length(box.min), glm::length(box.max)});
    const glm::vec3 pad(1e-3f * std::max({extent.x, extent.y, extent.z}) + 1e-6f * scale);
    return {glm::vec4(box.min - pad, 1.0f), glm::vec4(box.max + pad, 1.0f)};
}

float distanceSq(const glm::vec3& p, const scene::Aabb& box)
{
    const glm::vec3 d = glm::max(glm::max(box.min - p, p - box.max), glm::vec3(0.0f));
    return glm::dot(d, d);
}

// Where a front-to-back traversal of a view starts: the eye of a perspective view; for an
// orthographic one a point far behind the near plane's centre, so that distance from it
// orders boxes nearly as depth does.
glm::vec3 traversalOrigin(const glm::mat4& viewProj, float sceneRadius)
{
    const glm::mat4 inv = glm::inverse(viewProj);
    const glm::vec4 eye = inv * glm::vec4(0.0f, 0.0f, 1.0f, 0.0f);
    const glm::vec4 nearCentre = inv * glm::vec4(0.0f, 0.0f, 1.0f, 1.0f);
    const glm::vec3 centre = glm::vec3(nearCentre) / nearCentre.w;
    const float scale = std::max(glm::length(glm::vec3(eye)), 1e-30f);
    if (std::abs(eye.w) > 1e-6f * scale) return glm::vec3(eye) / eye.w;
    return centre + glm::normalize(glm::vec3(eye)) * (4.0f * std::max(sceneRadius, 1e-6f));
}

} // namespace

// One depth target the traversals draw into: the camera's (sampled by the receiver
// mask's scatter) or a light view's at its resolution, with its receiver masks.
struct Visibility::Target {
    uint32_t width = 0, height = 0;
    gpu::Image depth;
    VkImageLayout depthLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    gpu::Image mask, maskRows, maskDilated;  // light targets in receiver-mask mode
    uint32_t maskSize = 0;   // texels per side of the masks
    uint32_t maskBlock = 1;  // view texels per mask texel, per side
    gpu::Buffer maskReadback;            // the dilated mask, host-visible
    std::vector<uint32_t> maskSum;       // its summed-area table, (maskSize + 1)^2
    // Views whose technique compares with the receivers' own depth: the farthest receiver
    // depth per view texel, and the scratch of its spreading over the taps; made on
    // first use.
    gpu::Image receiverDepth, receiverDepthPrefix;

    // Whether no mask texel in `rect` (view texels, inclusive) is marked, so that no
    // fragment of a query inside it could pass the mask test.
    bool maskRejects(const TexelRect& rect) const
    {
        const float block = float(maskBlock), last = float(maskSize - 1);
        const float x0 = std::floor(rect.lo.x / block), y0 = std::floor(rect.lo.y / block);
        const float x1 = std::floor(rect.hi.x / block), y1 = std::floor(rect.hi.y / block);
        if (!(x1 >= 0.0f && y1 >= 0.0f && x0 <= last && y0 <= last)) return true;  // off the view
        const auto ix0 = size_t(std::max(x0, 0.0f)), iy0 = size_t(std::max(y0, 0.0f));
        const auto ix1 = size_t(std::min(x1, last)) + 1, iy1 = size_t(std::min(y1, last)) + 1;
        const size_t w = maskSize + 1;
        const uint64_t marked = uint64_t(maskSum[iy1 * w + ix1]) + maskSum[iy0 * w + ix0] - maskSum[iy0 * w + ix1] -
                                maskSum[iy1 * w + ix0];
        return marked == 0;
    }

    // The traversal's view.
    glm::mat4 viewProj{1.0f};
    bool useMask = false;
    VkRect2D area{};  // what the traversal renders: the view, or the receiver mask's bounds
    render::ShadowDepthBias bias;           // light views: the technique's, for leaf draws (boxes take none)
    int32_t compareTapRadius = -1;  // with useMask, >= 0: receiverDepth is tested too
    bool lightView = false;  // leaf draws take the technique's bias, and are kept only when they find samples
};

// Per (light, view): last frame's node visibility and this frame's caster list.
struct Visibility::ViewState {
    uint64_t frame = UINT64_MAX;
    glm::mat4 viewProj{0.0f};
    uint32_t resolution = 0;
    float footprint = -1.0f;
    render::ShadowDepthBias bias;
    int32_t compareTapRadius = -1;
    NodeHistory history;
    std::vector<uint8_t> casters;
    double keptFraction = 0.0;     // of the frustum's instances, at the last full culling
    uint32_t framesSinceFull = 0;  // frames culled to the frustum since then
};

Visibility::Visibility(gpu::Context& context, const gpu::ShaderCompiler& shaders, const scene::Scene& scene,
                       const render::SceneGpu& sceneGpu, config::CullingMode mode, uint32_t width, uint32_t height,
                       bool focus)
    : context_(context),
      scene_(scene),
      sceneGpu_(sceneGpu),
      mode_(mode),
      width_(width),
      height_(height),
      bvh_(scene::instanceWorldBounds(scene.instances)),
      focusing_(focus)
{
    if (focusing_ && mode_ != config::CullingMode::LightOcclusion && mode_ != config::CullingMode::ReceiverMask) {
        throw ConfigError(fmt::format("shadow_focus needs culling \"receiver-mask\" or \"light-occlusion\", not \"{}\"",
                                      config::cullingModeName(mode_)));
    }
    receivers_.assign(scene.instances.size(), 1);
    if (mode_ == config::CullingMode::None || mode_ == config::CullingMode::Frustum) return;

    // Only what the mode needs: occlusion modes get the query pipelines, receiver-mask
    // mode the mask pipelines too.
    const gpu::VertexLayout positions{sceneGpu_.vertexStride(),
                                      {{0, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(scene::Vertex, position)}}};
    gpu::GraphicsPipelineDesc d;
    d.vertexShader = "engine/shadow_depth.vert";
    d.bindings = {{0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER}};
    d.pushConstantBytes = sizeof(glm::mat4);
    d.vertexLayout = positions;
    d.depthFormat = kDepthFormat;
    d.depthCompare = VK_COMPARE_OP_GREATER_OR_EQUAL;
    d.depthBias = true;
    d.cullMode = VK_CULL_MODE_NONE;
    const auto make = [&](const char* name, bool depthWrite) {
        d.name = std::string("visibility.") + name;
        d.depthWrite = depthWrite;
        return gpu::Pipeline(context_, shaders, d);
    };
    leafDepth_ = make("leaf", true);
    leafCount_ = make("leaf_count", false);
    gpu::GraphicsPipelineDesc boxDesc = d;
    boxDesc.vertexShader = "engine/occlusion_box.vert";
    boxDesc.vertexLayout = {};
    boxDesc.name = "visibility.box";
    boxDesc.depthWrite = false;
    box_ = gpu::Pipeline(context_, shaders, boxDesc);
    if (mode_ == config::CullingMode::ReceiverMask) {
        d.fragmentShader = "engine/culling_mask.frag";
        d.defines = {{"CULLING_WORLD", "1"}};
        d.pushConstantBytes = sizeof(CulledQueryPush);
        d.bindings = {{0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},
                      {1, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER},
                      {2, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE}};
        maskLeafDepth_ = make("mask_leaf", true);
        maskLeafCount_ = make("mask_leaf_count", false);
        boxDesc.fragmentShader = d.fragmentShader;
        boxDesc.defines = d.defines;
        boxDesc.pushConstantBytes = d.pushConstantBytes;
        boxDesc.bindings = d.bindings;
        boxDesc.name = "visibility.mask_box";
        maskBox_ = gpu::Pipeline(context_, shaders, boxDesc);
        gpu::ComputePipelineDesc c;
        c.name = "visibility.receiver_scatter";
        c.shader = "engine/receiver_scatter.comp";
        c.bindings = {{0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER},
                      {1, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE},
                      {2, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER}};
        c.pushConstantBytes = sizeof(ScatterPush);
        scatter_ = gpu::Pipeline(context_, shaders, c);
        c.name = "visibility.receiver_depth_scatter";
        c.defines = {{"RECEIVER_DEPTH", "1"}};
        c.bindings.push_back({3, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE});
        scatterDepth_ = gpu::Pipeline(context_, shaders, c);
        // Separable filters over a radius, one axis per dispatch: bindings (source,
        // destination), push (size, radius, vertical).
        const auto imageFilter = [&](const char* name, const char* shader) {
            gpu::ComputePipelineDesc f;
            f.name = name;
            f.shader = shader;
            f.bindings = {{0, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE}, {1, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE}};
            f.pushConstantBytes = 3 * sizeof(int32_t);
            return gpu::Pipeline(context_, shaders, f);
        };
        depthMin_ = imageFilter("visibility.receiver_depth_min", "engine/receiver_depth_min.comp");
        dilate_ = imageFilter("visibility.dilate", "engine/mask_dilate.comp");
        // Bound in place of a target's receiver depth by views that have none.
        noReceiverDepth_ = gpu::Image(context_, {1, 1, kReceiverDepthFormat, VK_IMAGE_USAGE_STORAGE_BIT,
                                                 "visibility.no_receiver_depth"});
        context_.submitAndWait([&](VkCommandBuffer cmd) {
            gpu::transition(cmd, noReceiverDepth_, gpu::access::kUndefined,
                            {VK_IMAGE_LAYOUT_GENERAL, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, 0});
        });
        nearest_ = gpu::createSampler(context_, VK_FILTER_NEAREST, VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE);
        cameraData_ = gpu::Buffer(context_, sizeof(CameraData), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true,
                                  "visibility.camera");
    }

    // A node is queried at most three times in one traversal (in a multi-query, alone,
    // and as a drawn leaf); a tree over n instances has fewer than 2 n nodes.
    const uint64_t maxNodes = 2 * uint64_t(std::max<size_t>(scene.instances.size(), 1));
    queryCapacity_ = uint32_t(std::min<uint64_t>(3 * maxNodes + 64, UINT32_MAX));
    VkQueryPoolCreateInfo q{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
    q.queryType = VK_QUERY_TYPE_OCCLUSION;
    q.queryCount = queryCapacity_;
    PENUMBRA_VK(vkCreateQueryPool(context_.device(), &q, nullptr, &queries_));
    boxes_ = gpu::Buffer(context_, (maxNodes + 64) * sizeof(GpuBox), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true,
                         "visibility.boxes");

    camera_ = std::make_unique<Target>();
    camera_->width = width_;
    camera_->height = height_;
    camera_->depth = gpu::Image(context_, {width_, height_, kDepthFormat,
                                           VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT |
                                               VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                                           "visibility.camera_depth"});
}

Visibility::~Visibility()
{
    if (queries_) vkDestroyQueryPool(context_.device(), queries_, nullptr);
}

void Visibility::instancesMoved(std::span<const uint32_t> moved)
{
    const std::vector<scene::Aabb> bounds = scene::instanceWorldBounds(scene_.instances);
    if (bvh_.refitOrRebuild(bounds, moved).action == scene::RefitAction::Rebuilt) {
        // Node indices changed: last frame's visibility no longer names the same nodes.
        cameraHistory_ = {};
        for (auto& [key, view] : views_) view->history = {};
    }
}

void Visibility::cullFrustum(const glm::mat4& viewProj, std::vector<uint8_t>& visible) const
{
    std::vector<uint32_t> inside;
    bvh_.cullFrustum(scene::frustumFromViewProj(viewProj), inside);
    visible.assign(scene_.instances.size(), 0);
    for (const uint32_t i : inside) visible[i] = 1;
}

void Visibility::beginFrame(const glm::mat4& cameraViewProj)
{
    ++frame_;
    stats_ = {};
    cameraViewProj_ = cameraViewProj;
    const auto start = std::chrono::steady_clock::now();
    switch (mode_) {
    case config::CullingMode::None: receivers_.assign(scene_.instances.size(), 1); break;
    case config::CullingMode::Frustum: cullFrustum(cameraViewProj, receivers_); break;
    case config::CullingMode::LightOcclusion:
    case config::CullingMode::ReceiverMask: {
        // As for light views (cullLightView): a view where the last full culling kept
        // most of the frustum's instances (a bird's-eye view) takes its frustum, and is
        // culled in full again every kRecheckFrames frames, on the same frames as the
        // light views. Without the culling pass there is no camera depth, so the
        // receiver masks wait for the next full frame too. Focusing needs the depth on
        // every frame.
        cameraDepthValid_ = false;
        if (!focusing_ && cameraKeptFraction_ > kFallbackKeptFraction && cameraFramesSinceFull_ < kRecheckFrames) {
            cullFrustum(cameraViewProj, receivers_);
            ++cameraFramesSinceFull_;
            stats_.cameraFellBack = 1;
            break;
        }
        Target& t = *camera_;
        t.viewProj = cameraViewProj;
        t.area = {{0, 0}, {t.width, t.height}};
        t.useMask = false;
        t.lightView = false;
        occlusionCull(t, cameraHistory_, receivers_);
        cameraDepthValid_ = true;
        std::vector<uint8_t> inFrustum;
        cullFrustum(cameraViewProj, inFrustum);
        const auto framed = double(std::count(inFrustum.begin(), inFrustum.end(), uint8_t(1)));
        const auto seen = double(std::count(receivers_.begin(), receivers_.end(), uint8_t(1)));
        cameraKeptFraction_ = framed > 0.0 ? seen / framed : 0.0;
        cameraFramesSinceFull_ = 0;
        if (focusing_) computeFocus(cameraViewProj);
        if (mode_ == config::CullingMode::ReceiverMask) {
            // The receiver passes sample the camera depth.
            context_.submitAndWait([&](VkCommandBuffer cmd) {
                gpu::transition(cmd, t.depth, {t.depthLayout, gpu::access::kDepthAttachment.stage,
                                               gpu::access::kDepthAttachment.access},
                                {VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL, VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT,
                                 VK_ACCESS_2_SHADER_SAMPLED_READ_BIT});
            });
            t.depthLayout = VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL;
            CameraData data{glm::inverse(cameraViewProj), glm::vec4(float(width_), float(height_), 0.0f, 0.0f),
                            glm::vec4(traversalOrigin(cameraViewProj, scene_.bounds().radius()), 0.0f)};
            std::memcpy(cameraData_.mapped(), &data, sizeof(data));
        }
        break;
    }
    }
    stats_.receivers = uint64_t(std::count(receivers_.begin(), receivers_.end(), uint8_t(1)));
    stats_.cameraMs = msSince(start);
}

void Visibility::computeFocus(const glm::mat4& cameraViewProj)
{
    const std::vector<float> depth = gpu::readImageFloats(context_, camera_->depth, camera_->depthLayout);
    const glm::mat4 inverse = glm::inverse(cameraViewProj);
    focus_ = {};
    for (uint32_t y = 0; y < height_; ++y) {
        for (uint32_t x = 0; x < width_; ++x) {
            const float d = depth[size_t(y) * width_ + x];
            if (!(d > 0.0f)) continue;  // nothing drawn (reversed-Z far is 0)
            // The pixel's corners, not its centre: the whole pixel's footprint stays in.
            for (int corner = 0; corner < 4; ++corner) {
                const glm::vec2 ndc((float(x) + float(corner & 1)) / float(width_) * 2.0f - 1.0f,
                                    (float(y) + float(corner >> 1)) / float(height_) * 2.0f - 1.0f);
                const glm::vec4 world = inverse * glm::vec4(ndc, d, 1.0f);
                if (world.w != 0.0f) focus_.extend(glm::vec3(world) / world.w);
            }
        }
    }
}

void Visibility::countDraw(const render::DrawCounts& counts)
{
    stats_.castersDrawn += counts.instances;
    stats_.trianglesDrawn += counts.triangles;
}

const std::vector<uint8_t>* Visibility::casters(const render::CasterView& view)
{
    if (mode_ == config::CullingMode::None) return nullptr;
    std::unique_ptr<ViewState>& state = views_[{view.light, view.view}];
    if (!state) state = std::make_unique<ViewState>();
    ViewState& s = *state;
    if (s.frame != frame_ || s.viewProj != view.viewProj || s.resolution != view.resolution ||
        s.footprint != view.footprintTexels || s.bias != view.depthBias || s.compareTapRadius != view.compareTapRadius) {
        cullLightView(view, s);
        s.frame = frame_;
        s.viewProj = view.viewProj;
        s.resolution = view.resolution;
        s.footprint = view.footprintTexels;
        s.bias = view.depthBias;
        s.compareTapRadius = view.compareTapRadius;
    }
    return &s.casters;
}

Visibility::Target& Visibility::lightTarget(uint32_t resolution)
{
    std::unique_ptr<Target>& t = lightTargets_[resolution];
    if (t) return *t;
    t = std::make_unique<Target>();
    t->width = t->height = resolution;
    const std::string name = fmt::format("visibility.light{}", resolution);
    t->depth = gpu::Image(context_, {resolution, resolution, kDepthFormat, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT,
                                     name + ".depth"});
    if (mode_ == config::CullingMode::ReceiverMask) {
        const VkImageUsageFlags usage =
            VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
        t->maskBlock = (resolution + kMaxMaskTexels - 1) / kMaxMaskTexels;
        t->maskSize = (resolution + t->maskBlock - 1) / t->maskBlock;
        const uint32_t m = t->maskSize;
        t->mask = gpu::Image(context_, {m, m, kMaskFormat, usage, name + ".mask"});
        t->maskRows = gpu::Image(context_, {m, m, kMaskFormat, usage, name + ".mask_rows"});
        t->maskDilated = gpu::Image(context_, {m, m, kMaskFormat, usage | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                                               name + ".mask_dilated"});
        t->maskReadback = gpu::Buffer(context_, VkDeviceSize(m) * m, VK_BUFFER_USAGE_TRANSFER_DST_BIT, true,
                                      name + ".mask_readback");
        context_.submitAndWait([&](VkCommandBuffer cmd) {
            for (const gpu::Image* image : {&t->mask, &t->maskRows, &t->maskDilated})
                gpu::transition(cmd, *image, gpu::access::kUndefined,
                                {VK_IMAGE_LAYOUT_GENERAL, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, 0});
        });
    }
    return *t;
}

void Visibility::makeReceiverDepth(Target& t, bool withPrefix)
{
    const VkImageUsageFlags usage = VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
    const std::string name = fmt::format("visibility.light{}", t.width);
    std::vector<gpu::Image*> made;
    if (!t.receiverDepth.handle()) {
        t.receiverDepth = gpu::Image(context_, {t.width, t.height, kReceiverDepthFormat, usage, name + ".receiver_depth"});
        made.push_back(&t.receiverDepth);
    }
    if (withPrefix && !t.receiverDepthPrefix.handle()) {
        t.receiverDepthPrefix =
            gpu::Image(context_, {t.width, t.height, kReceiverDepthFormat, usage, name + ".receiver_depth_prefix"});
        made.push_back(&t.receiverDepthPrefix);
    }
    if (made.empty()) return;
    context_.submitAndWait([&](VkCommandBuffer cmd) {
        for (gpu::Image* image : made)
            gpu::transition(cmd, *image, gpu::access::kUndefined,
                            {VK_IMAGE_LAYOUT_GENERAL, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, 0});
    });
}

void Visibility::cullLightView(const render::CasterView& view, ViewState& s)
{
    ++stats_.views;
    const auto start = std::chrono::steady_clock::now();
    if (mode_ == config::CullingMode::Frustum || view.resolution == 0) {
        cullFrustum(view.viewProj, s.casters);
        stats_.casterCullMs += msSince(start);
        return;
    }
    // Culling that cannot pay is skipped: when the last full culling of this view kept
    // most of the instances in its frustum (a bird's-eye view, where the queries cost more
    // than the draws they save), the view takes its frustum's instances, a superset, and
    // is culled in full again every kRecheckFrames frames.
    const bool noMask = mode_ == config::CullingMode::ReceiverMask && !cameraDepthValid_;
    if (noMask || (s.keptFraction > kFallbackKeptFraction && s.framesSinceFull < kRecheckFrames)) {
        cullFrustum(view.viewProj, s.casters);
        ++s.framesSinceFull;
        ++stats_.viewsFellBack;
        stats_.casterCullMs += msSince(start);
        return;
    }
    cullLightViewFully(view, s);
    std::vector<uint8_t> inFrustum;
    cullFrustum(view.viewProj, inFrustum);
    const auto framed = double(std::count(inFrustum.begin(), inFrustum.end(), uint8_t(1)));
    const auto kept = double(std::count(s.casters.begin(), s.casters.end(), uint8_t(1)));
    s.keptFraction = framed > 0.0 ? kept / framed : 0.0;
    s.framesSinceFull = 0;
}

void Visibility::cullLightViewFully(const render::CasterView& view, ViewState& s)
{
    auto start = std::chrono::steady_clock::now();
    Target& t = lightTarget(view.resolution);
    t.viewProj = view.viewProj;
    t.lightView = true;
    t.bias = view.depthBias;
    t.area = {{0, 0}, {t.width, t.height}};
    if (mode_ == config::CullingMode::LightOcclusion) {
        t.useMask = false;
        occlusionCull(t, s.history, s.casters);
        stats_.casterCullMs += msSince(start);
        return;
    }

    // Step 2: the receiver mask. The texels the camera's pixels see are marked
    // (receiver_scatter.comp: the reverse shadow test, from the camera's side), the mask
    // is dilated by the view's footprint and read back, for the traversal to skip without
    // a query the nodes whose projection meets no mask texel.
    //
    // The paper also rasterises the receivers' depth here, as the start of the shadow map.
    // Here the technique draws its own map, so that pass would draw the receivers twice
    // (in a bird's-eye view, most of the scene: measured 400 ms of 1.3 s on lavapipe,
    // docs/culling.md). The queries are tested against the depth of what the traversal
    // itself draws instead; it is all drawn into the technique's map too, so a node
    // behind it at every masked texel is still one that cannot change a masked texel.
    const uint32_t size = view.resolution;
    // The reach in mask texels: a view texel within `reach` of a marked one lies in a mask
    // texel within ceil(reach / block) of the marked one's.
    const float reach = std::min(view.footprintTexels, float(size)) + kMaskSafetyTexels;
    const auto radius = int32_t(std::min(std::ceil(std::max(reach, 0.0f) / float(t.maskBlock)), float(t.maskSize)));
    // The receiver depths, for a technique that compares with them (culling_mask.frag).
    const bool ownDepth = view.compareTapRadius >= 0;
    const int32_t tapRadius = std::min(view.compareTapRadius, int32_t(size));
    if (ownDepth) makeReceiverDepth(t, tapRadius > 0);
    context_.submitAndWait([&](VkCommandBuffer cmd) {
        // The previous submission's reads and writes of these images (the last view).
        gpu::memoryBarrier(cmd, {VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_WRITE_BIT},
                           {VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT});
        const VkClearColorValue zero{{0.0f, 0.0f, 0.0f, 0.0f}};
        const VkImageSubresourceRange colorRange{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
        vkCmdClearColorImage(cmd, t.mask.handle(), VK_IMAGE_LAYOUT_GENERAL, &zero, 1, &colorRange);
        if (ownDepth) {
            const VkClearColorValue none{.uint32 = {~0u, 0u, 0u, 0u}};
            vkCmdClearColorImage(cmd, t.receiverDepth.handle(), VK_IMAGE_LAYOUT_GENERAL, &none, 1, &colorRange);
        }
        gpu::memoryBarrier(cmd, {VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_WRITE_BIT},
                           {VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT});
        // The texels the camera's pixels look up, and their depths (receiver_scatter.comp).
        const gpu::Pipeline& scatter = ownDepth ? scatterDepth_ : scatter_;
        scatter.bind(cmd);
        gpu::DescriptorPush scatterBindings;
        scatterBindings.sampledImage(0, camera_->depth, nearest_, VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL)
            .storageImage(1, t.mask)
            .storageBuffer(2, cameraData_);
        if (ownDepth) scatterBindings.storageImage(3, t.receiverDepth);
        scatterBindings.push(context_, cmd, scatter);
        const ScatterPush scatterPush{view.viewProj, int32_t(t.maskBlock), int32_t(size)};
        scatter.pushConstants(cmd, &scatterPush, sizeof(scatterPush));
        vkCmdDispatch(cmd, (width_ + 7) / 8, (height_ + 7) / 8, 1);

        const gpu::MemoryAccess stores{VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                                       VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT};
        const gpu::MemoryAccess loads{VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT,
                                      VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT |
                                          VK_ACCESS_2_SHADER_SAMPLED_READ_BIT};
        gpu::memoryBarrier(cmd, stores, loads);
        if (ownDepth && tapRadius > 0) {
            // Each receiver's depth over the texels its taps read (receiver_depth_min.comp).
            depthMin_.bind(cmd);
            gpu::DescriptorPush()
                .storageImage(0, t.receiverDepth)
                .storageImage(1, t.receiverDepthPrefix)
                .push(context_, cmd, depthMin_);
            for (int32_t vertical = 0; vertical < 2; ++vertical) {
                const int32_t push[3] = {int32_t(size), tapRadius, vertical};
                depthMin_.pushConstants(cmd, push, sizeof(push));
                vkCmdDispatch(cmd, (size + 63) / 64, 1, 1);
                gpu::memoryBarrier(cmd, stores, loads);
            }
        }
        dilate_.bind(cmd);
        const gpu::Image* passes[2][2] = {{&t.mask, &t.maskRows}, {&t.maskRows, &t.maskDilated}};
        for (int32_t vertical = 0; vertical < 2; ++vertical) {
            gpu::DescriptorPush()
                .storageImage(0, *passes[vertical][0])
                .storageImage(1, *passes[vertical][1])
                .push(context_, cmd, dilate_);
            const int32_t push[3] = {int32_t(t.maskSize), radius, vertical};
            dilate_.pushConstants(cmd, push, sizeof(push));
            vkCmdDispatch(cmd, (t.maskSize + 63) / 64, 1, 1);
            gpu::memoryBarrier(cmd, stores, loads);
        }
        const gpu::ImageAccess general{VK_IMAGE_LAYOUT_GENERAL, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                                       VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT};
        const gpu::ImageAccess copySource{VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, VK_PIPELINE_STAGE_2_COPY_BIT,
                                          VK_ACCESS_2_TRANSFER_READ_BIT};
        gpu::transition(cmd, t.maskDilated, general, copySource);
        VkBufferImageCopy copy{};
        copy.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        copy.imageExtent = {t.maskSize, t.maskSize, 1};
        vkCmdCopyImageToBuffer(cmd, t.maskDilated.handle(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, t.maskReadback.handle(),
                               1, &copy);
        // Back to GENERAL for the queries' sampled reads.
        gpu::transition(cmd, t.maskDilated, copySource,
                        {VK_IMAGE_LAYOUT_GENERAL, VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT});
        gpu::memoryBarrier(cmd, {VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT},
                           {VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT});
    });
    // A summed-area table of the mask: whether any texel of a rectangle is marked, in O(1).
    const uint32_t m = t.maskSize;
    const auto* texels = static_cast<const uint8_t*>(t.maskReadback.mapped());
    t.maskSum.assign(size_t(m + 1) * (m + 1), 0);
    uint32_t x0 = m, y0 = m, x1 = 0, y1 = 0;  // the marked texels' bounds, inclusive
    for (uint32_t y = 0; y < m; ++y) {
        uint32_t row = 0;
        for (uint32_t x = 0; x < m; ++x) {
            const bool marked = texels[size_t(y) * m + x] >= 128;
            row += marked ? 1u : 0u;
            t.maskSum[size_t(y + 1) * (m + 1) + x + 1] = t.maskSum[size_t(y) * (m + 1) + x + 1] + row;
            if (marked) {
                x0 = std::min(x0, x);
                x1 = std::max(x1, x);
                y0 = std::min(y0, y);
                y1 = std::max(y1, y);
            }
        }
    }
    // The queries render only there (render area and scissor; the viewport, and so every
    // texel centre, stays the view's): no sample outside it could pass the mask, and
    // lavapipe's cost per query grows with the area it bins, not only with what is drawn.
    // An empty mask keeps one texel: the traversal then rejects every node.
    if (x0 > x1) x0 = x1 = y0 = y1 = 0;
    const uint32_t b = t.maskBlock;
    t.area = {{int32_t(x0 * b), int32_t(y0 * b)},
              {std::min((x1 + 1) * b, size) - x0 * b, std::min((y1 + 1) * b, size) - y0 * b}};
    stats_.maskMs += msSince(start);

    // Step 3: casters against the mask, or against the receiver depths.
    start = std::chrono::steady_clock::now();
    t.useMask = true;
    t.compareTapRadius = view.compareTapRadius;
    occlusionCull(t, s.history, s.casters);
    stats_.casterCullMs += msSince(start);
}

void Visibility::occlusionCull(Target& t, NodeHistory& history, std::vector<uint8_t>& visible)
{
    std::vector<uint8_t>& nodeVisible = history.visible;
    std::vector<uint16_t>& hidden = history.hidden;
    const size_t nodeCount = bvh_.nodeCount();
    visible.assign(scene_.instances.size(), 0);
    if (nodeVisible.size() != nodeCount) {
        // First frame, or a rebuilt tree: nothing is known, so the root is queried.
        nodeVisible.assign(nodeCount, 0);
        hidden.assign(nodeCount, 0);
        history.emptyDraws.assign(nodeCount, 0);
    }
    if (nodeCount == 0) return;

    const scene::Frustum frustum = scene::frustumFromViewProj(t.viewProj);
    const glm::vec3 origin = traversalOrigin(t.viewProj, scene_.bounds().radius());
    std::vector<uint8_t> nextVisible(nodeCount, 0);

    enum class Kind { Box, Batch, Leaf };
    struct Query {
        Kind kind;
        uint32_t node;        // Box, Leaf
        uint32_t batchFirst;  // Batch: range in batchNodes
        uint32_t batchCount;
    };
    struct Seed {
        uint32_t node;
        bool alone;  // queried on its own (a multi-query that found samples)
    };
    std::vector<Query> issued;
    std::vector<uint32_t> batchNodes;
    std::vector<Seed> seeds{{0, false}};
    std::vector<uint32_t> leavesToDraw;
    auto* boxes = static_cast<GpuBox*>(boxes_.mapped());
    const size_t boxCapacity = boxes_.size() / sizeof(GpuBox);
    uint32_t queryBase = 0;
    bool firstRound = true;
    const gpu::MemoryAccess anyWrite{VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_WRITE_BIT};
    const gpu::MemoryAccess anyAccess{VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                                      VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT};

    while (!seeds.empty() || !leavesToDraw.empty()) {
        issued.clear();
        batchNodes.clear();
        context_.submitAndWait([&](VkCommandBuffer cmd) {
            // The previous submission's writes (last round, last view, last frame).
            gpu::memoryBarrier(cmd, anyWrite, anyAccess);
            if (firstRound) vkCmdResetQueryPool(cmd, queries_, 0, queryCapacity_);
            if (t.depthLayout != VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL) {
                gpu::transition(cmd, t.depth,
                                {t.depthLayout, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_READ_BIT},
                                gpu::access::kDepthAttachment);
                t.depthLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
            }
            VkRenderingAttachmentInfo depth{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
            depth.imageView = t.depth.view();
            depth.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
            depth.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
            depth.clearValue.depthStencil = {0.0f, 0};
            VkRenderingInfo info{VK_STRUCTURE_TYPE_RENDERING_INFO};
            info.renderArea = t.area;
            info.layerCount = 1;
            info.pDepthAttachment = &depth;
            const gpu::Pipeline* bound = nullptr;
            uint32_t inRendering = 0;
            const auto begin = [&](bool clear) {
                depth.loadOp = clear ? VK_ATTACHMENT_LOAD_OP_CLEAR : VK_ATTACHMENT_LOAD_OP_LOAD;
                vkCmdBeginRendering(cmd, &info);
                const VkViewport viewport{0.0f, 0.0f, float(t.width), float(t.height), 0.0f, 1.0f};
                const VkRect2D scissor = t.area;
                vkCmdSetViewport(cmd, 0, 1, &viewport);
                vkCmdSetScissor(cmd, 0, 1, &scissor);
                bound = nullptr;
                inRendering = 0;
            };
            begin(firstRound);
            const auto use = [&](const gpu::Pipeline& p, bool boxPipeline) {
                if (bound == &p) return;
                p.bind(cmd);
                gpu::DescriptorPush push;
                push.storageBuffer(0, boxPipeline ? boxes_ : sceneGpu_.instanceBuffer());
                const bool ownDepth = t.useMask && t.compareTapRadius >= 0;
                if (t.useMask) {
                    push.sampledImage(1, t.maskDilated, nearest_, VK_IMAGE_LAYOUT_GENERAL)
                        .storageImage(2, ownDepth ? t.receiverDepth : noReceiverDepth_);
                }
                push.push(context_, cmd, p);
                // Leaf draws take the technique's bias in a light view, so that what they
                // draw and what their queries count is the technique's own map (reversed-Z:
                // negated, as in render::ShadowMap). Box proxies take none: the geometry
                // inside lies behind their faces, biased or not.
                const render::ShadowDepthBias bias = t.lightView && !boxPipeline ? t.bias : render::ShadowDepthBias{};
                vkCmdSetDepthBias(cmd, -bias.constant, -bias.clamp, -bias.slope);
                const CulledQueryPush constants{t.viewProj, int32_t(t.maskBlock), ownDepth ? 1 : 0, bias.slope,
                                                bias.clamp};
                p.pushConstants(cmd, &constants, t.useMask ? sizeof(constants) : sizeof(glm::mat4));
                bound = &p;
            };
            const auto beginQuery = [&]() {
                if (inRendering == kQueriesPerRendering) {
                    vkCmdEndRendering(cmd);
                    gpu::memoryBarrier(cmd,
                                       {VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
                                        VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT},
                                       {VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT |
                                            VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
                                        VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT |
                                            VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT});
                    begin(false);
                }
                const uint32_t index = queryBase + uint32_t(issued.size());
                if (index >= queryCapacity_) throw Error("visibility: occlusion query pool exhausted");
                vkCmdBeginQuery(cmd, queries_, index, 0);
                ++inRendering;
                ++stats_.queriesIssued;
            };
            const auto endQuery = [&](const Query& q) {
                vkCmdEndQuery(cmd, queries_, queryBase + uint32_t(issued.size()));
                issued.push_back(q);
            };
            uint32_t boxCount = 0;
            const auto pushBox = [&](uint32_t node) {
                if (boxCount >= boxCapacity) throw Error("visibility: box buffer exhausted");
                boxes[boxCount] = inflated(bvh_.nodeBounds(node));
                return boxCount++;
            };
            const auto drawLeaf = [&](uint32_t node) {
                const std::span<const uint32_t> instances = bvh_.leafInstances(node);
                beginQuery();
                for (const bool alphaMasked : {false, true}) {
                    // Alpha-masked instances are counted but write no depth: their holes
                    // must not occlude.
                    const gpu::Pipeline& p = t.useMask ? (alphaMasked ? maskLeafCount_ : maskLeafDepth_)
                                                       : (alphaMasked ? leafCount_ : leafDepth_);
                    use(p, false);
                    sceneGpu_.drawInstances(cmd, instances, alphaMasked);
                }
                endQuery({Kind::Leaf, node, 0, 0});
                // The camera keeps what it draws (the G-buffer follows this list); a light
                // view keeps a leaf when its draw finds samples (below).
                if (!t.lightView)
                    for (const uint32_t i : instances) visible[i] = 1;
            };
            std::vector<uint32_t> batch;
            const auto flushBatch = [&]() {
                if (batch.empty()) return;
                if (batch.size() == 1) {
                    const uint32_t b = pushBox(batch[0]);
                    use(t.useMask ? maskBox_ : box_, true);
                    beginQuery();
                    vkCmdDraw(cmd, 36, 1, 0, b);
                    endQuery({Kind::Box, batch[0], 0, 0});
                } else {
                    const uint32_t firstBox = boxCount;
                    for (const uint32_t n : batch) pushBox(n);
                    use(t.useMask ? maskBox_ : box_, true);
                    beginQuery();
                    vkCmdDraw(cmd, 36, uint32_t(batch.size()), 0, firstBox);
                    endQuery({Kind::Batch, 0, uint32_t(batchNodes.size()), uint32_t(batch.size())});
                    batchNodes.insert(batchNodes.end(), batch.begin(), batch.end());
                }
                batch.clear();
            };
            const auto queryBox = [&](uint32_t node, bool alone) {
                if (!alone && hidden[node] >= kMultiQueryAfterFrames) {
                    batch.push_back(node);
                    if (batch.size() == kMultiQueryBatch) flushBatch();
                    return;
                }
                const uint32_t b = pushBox(node);
                use(t.useMask ? maskBox_ : box_, true);
                beginQuery();
                vkCmdDraw(cmd, 36, 1, 0, b);
                endQuery({Kind::Box, node, 0, 0});
            };

            // Leaves found visible in the last round are drawn first: they occlude.
            for (const uint32_t leaf : leavesToDraw) drawLeaf(leaf);

            // Front to back from the seeds (CHC++'s traversal queue).
            struct Entry {
                float distanceSq;
                uint32_t node;
                bool alone;
            };
            const auto farther = [](const Entry& a, const Entry& b) {
                return a.distanceSq > b.distanceSq || (a.distanceSq == b.distanceSq && a.node > b.node);
            };
            std::vector<Entry> heap;
            const auto push = [&](uint32_t node, bool alone) {
                const scene::Aabb& box = bvh_.nodeBounds(node);
                if (box.empty()) return;
                heap.push_back({distanceSq(origin, box), node, alone});
                std::push_heap(heap.begin(), heap.end(), farther);
            };
            for (const Seed& s : seeds) push(s.node, s.alone);
            while (!heap.empty()) {
                std::pop_heap(heap.begin(), heap.end(), farther);
                const Entry e = heap.back();
                heap.pop_back();
                ++stats_.nodesVisited;
                const scene::Aabb& box = bvh_.nodeBounds(e.node);
                if (outside(frustum, box)) continue;
                const std::optional<TexelRect> rect = projectedRect(t.viewProj, box, t.width, t.height);
                if (t.useMask && rect && t.maskRejects(*rect)) {
                    ++stats_.maskRejected;
                    continue;
                }
                // No projection (the box reaches the near plane): visible without a query.
                // An inner node whose proxy would cover a large part of the view is opened
                // without one too: its query would cost as much as its children's and
                // would rarely find nothing (lavapipe rasterises every covered texel).
                const bool known = nodeVisible[e.node] != 0 || !rect ||
                                   (!bvh_.isLeafNode(e.node) && rect->area() > kOpenWithoutQueryFraction *
                                                                                   float(t.width) * float(t.height));
                if (bvh_.isLeafNode(e.node)) {
                    if (known)
                        drawLeaf(e.node);
                    else
                        queryBox(e.node, e.alone);
                } else if (known) {
                    push(bvh_.firstChild(e.node), false);
                    push(bvh_.firstChild(e.node) + 1, false);
                } else {
                    queryBox(e.node, e.alone);
                }
            }
            flushBatch();
            vkCmdEndRendering(cmd);
        });
        ++stats_.queryRounds;
        firstRound = false;

        // The round's results: what to draw and query next.
        std::vector<uint64_t> samples(issued.size(), 0);
        if (!issued.empty()) {
            PENUMBRA_VK(vkGetQueryPoolResults(context_.device(), queries_, queryBase, uint32_t(issued.size()),
                                                    samples.size() * sizeof(uint64_t), samples.data(), sizeof(uint64_t),
                                                    VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT));
        }
        queryBase += uint32_t(issued.size());
        seeds.clear();
        leavesToDraw.clear();
        for (size_t i = 0; i < issued.size(); ++i) {
            const Query& q = issued[i];
            if (samples[i] == 0) {
                if (q.kind == Kind::Leaf && history.emptyDraws[q.node] < kEmptyDrawFrames) {
                    nextVisible[q.node] = 1;  // drawn without waiting next frame too
                    ++history.emptyDraws[q.node];
                }
                continue;
            }
            switch (q.kind) {
            case Kind::Leaf:
                nextVisible[q.node] = 1;
                history.emptyDraws[q.node] = 0;
                // A light view's leaf whose draw found no sample lies, at every texel that
                // a receiver reads and where it lies in front of one, behind casters drawn
                // before it in the technique's own biased depth: it cannot change what a
                // receiver gets, though its box showed (a large lit receiver's box does).
                if (t.lightView)
                    for (const uint32_t i : bvh_.leafInstances(q.node)) visible[i] = 1;
                break;
            case Kind::Box:
                // A node whose box shows is opened (or, a leaf, drawn) without waiting
                // next frame, even if its own geometry turns out hidden: otherwise a box
                // that shows around hidden geometry would send its subtree through the
                // same chain of rounds every frame. A leaf drawn that way is queried by
                // its draw, which unmarks it when the geometry stays hidden (after
                // kEmptyDrawFrames such draws).
                nextVisible[q.node] = 1;
                history.emptyDraws[q.node] = 0;
                if (bvh_.isLeafNode(q.node)) {
                    leavesToDraw.push_back(q.node);
                } else {
                    seeds.push_back({bvh_.firstChild(q.node), false});
                    seeds.push_back({bvh_.firstChild(q.node) + 1, false});
                }
                break;
            case Kind::Batch:
                for (uint32_t k = 0; k < q.batchCount; ++k) seeds.push_back({batchNodes[q.batchFirst + k], true});
                break;
            }
        }
    }

    // Visibility pulled up the tree for the next frame (children come after parents).
    for (size_t n = nodeCount; n-- > 1;)
        if (nextVisible[n]) nextVisible[bvh_.parentNode(uint32_t(n))] = 1;
    for (size_t n = 0; n < nodeCount; ++n) hidden[n] = nextVisible[n] ? 0 : uint16_t(std::min(hidden[n] + 1, 0xffff));
    nodeVisible.swap(nextVisible);
}

} // namespace penumbra::visibility
