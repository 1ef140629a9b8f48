#include "RasterReference.h"

#include "penumbra/core/Error.h"
#include "penumbra/gpu/Context.h"
#include "penumbra/plugin/ComputePipeline.h"
#include "penumbra/graph/PassContext.h"
#include "penumbra/graph/RenderGraph.h"

#include <fmt/format.h>

#include <algorithm>
#include <cstring>

namespace penumbra::reference {
namespace {

// Graph layout. A pass per sample (a depth pass and a compare dispatch each) would put
// 512 passes and 256 transient images into the graph of a 256-sample frame. Instead the
// samples go in batches: one depth pass draws a batch's maps side by side into one
// image (ShadowMap::recordDepthMaps, with the pipelines created once), one dispatch
// compares every pixel with each of them and adds to a running sum; the batches' images
// have disjoint lifetimes, so the graph aliases them into one block of memory. The
// budget below bounds that block: 2^24 texels (64 MiB of D32), ten 512-texel cube atlases.
constexpr uint64_t kBatchTexels = uint64_t(1) << 24;

// A map per sample: beyond a few thousand the graph's passes (two per batch) and the
// frame's time grow past any use; the ray tracer takes up to 65536.
constexpr uint32_t kMaxSamples = 4096;

// The rasterizer's constant bias in r (minimum resolvable depth differences), the hard
// plugin's default; the receiver plane bias does the real work (no slope-scaled term: it
// would push shadows away from their casters, which a reference must not).
constexpr render::ShadowDepthBias kDepthBias{4.0f, 0.0f, 0.0f};

struct AccumulatePush {
    glm::vec4 sphere{0.0f};  // xyz centre, w radius of a sphere light; w = 0: every sample weighs 1
    uint32_t firstSample = 0;
    uint32_t sampleCount = 0;
    uint32_t gridColumns = 1;
    uint32_t gridRows = 1;
};
static_assert(sizeof(AccumulatePush) == 32);

// The light that renders sample `point` of `light`'s hard shadow: a point light at a
// point of a rect, disk or sphere (its cube atlas has the light's face count, 6), the
// sun along one direction of its cone, a spot light itself (its only sample).
scene::Light sampleLight(const scene::Light& light, const LightPoint& point)
{
    scene::Light s = light;
    if (light.type == scene::LightType::Spot) return s;
    s.sizeWorld = glm::vec2(0.0f);
    s.radiusWorld = 0.0f;
    s.angularDiameterDeg = 0.0f;
    if (point.isDirection) {
        s.direction = -glm::vec3(point.value);
    } else {
        s.type = scene::LightType::Point;
        s.position = glm::vec3(point.value);
    }
    return s;
}

// `resolution` per face, checked here so that the error names this plugin's parameter.
uint32_t checkedMapResolution(const plugin::TechniqueSetup& setup, uint32_t resolution)
{
    const uint32_t faces = render::shadowFaceCount(setup.light.type);
    const uint32_t perRow = faces == render::kMaxShadowFaces ? 3u : 1u;
    const uint32_t maxDimension = setup.context.properties().limits.maxImageDimension2D;
    if (uint64_t(resolution) * perRow > maxDimension) {
        throw ConfigError(fmt::format("reference: map_resolution: {} texels per face needs a {}-texel wide map for a {} "
                                      "light, more than this device's largest image ({}); use at most {}",
                                      resolution, uint64_t(resolution) * perRow, scene::lightTypeName(setup.light.type),
                                      maxDimension, maxDimension / perRow));
    }
    return resolution;
}

} // namespace

RasterReference::RasterReference(const plugin::TechniqueSetup& setup, const RasterSettings& settings)
    : context_(setup.context),
      settings_(settings),
      lightIndex_(setup.lightIndex),
      width_(setup.width),
      height_(setup.height),
      sampleCount_(LightSampler(setup.light).sampleCount(settings.samples)),
      shape_(setup, checkedMapResolution(setup, settings.mapResolution), "reference"),
      light_(setup.light)
{
    if (sampleCount_ > kMaxSamples) {
        throw ConfigError(fmt::format("reference: samples: brute_force renders one shadow map per sample and takes at "
                                      "most {}, got {}; use mode ray_traced for more",
                                      kMaxSamples, sampleCount_));
    }
    // Batches: as many maps as the texel budget allows (at least one), in a grid no wider
    // or taller than the device's largest image (one map fits: checked above).
    const uint32_t maxDimension = context_.properties().limits.maxImageDimension2D;
    const uint64_t mapTexels = uint64_t(shape_.atlasWidth()) * shape_.atlasHeight();
    const uint32_t columns = std::max(1u, maxDimension / shape_.atlasWidth());
    const uint32_t rows = std::max(1u, maxDimension / shape_.atlasHeight());
    mapsPerBatch_ = uint32_t(std::clamp<uint64_t>(kBatchTexels / std::max<uint64_t>(mapTexels, 1), 1,
                                                  std::min<uint64_t>(sampleCount_, uint64_t(columns) * rows)));
    gridColumns_ = std::min(mapsPerBatch_, columns);
    for (uint32_t first = 0; first < sampleCount_; first += mapsPerBatch_) {
        const uint32_t count = std::min(mapsPerBatch_, sampleCount_ - first);
        batches_.push_back({first, count, (count + gridColumns_ - 1) / gridColumns_});
    }

    sampleMaps_ = gpu::Buffer(context_, VkDeviceSize(sampleCount_) * sizeof(render::ShadowMapData),
                              VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true,
                              setup.local("sample_maps"));

    accumulate_ = plugin::createComputePipeline(setup, "accumulate", "accumulate.comp", {}, sizeof(AccumulatePush));
    // The first batch has no sums to read: a variant without that binding (binding its
    // own output there instead would be a read the graph's barriers do not order).
    accumulateFirst_ = plugin::createComputePipeline(setup, "accumulate.first", "accumulate.comp",
                                                     {{"FIRST_BATCH", "1"}}, sizeof(AccumulatePush));
    resolve_ = plugin::createComputePipeline(setup, "resolve", "resolve.comp");

    // One nearest compare per sample: the hard shadow of a point (or direction) of the
    // light; the softness comes from the samples alone.
    compareSampler_ = render::createShadowCompareSampler(context_);
    update(setup.light, setup.sceneBounds);
}

void RasterReference::update(const scene::Light& light, const scene::Aabb& sceneBounds)
{
    light_ = light;
    const LightSampler sampler(light);
    if (sampler.sampleCount(settings_.samples) != sampleCount_) {
        throw Error(fmt::format("reference (light {}): the light changed between a light with extent and one without; "
                                "brute_force sized its maps for {} sample(s)",
                                lightIndex_, sampleCount_));
    }
    // The ray tracer's pattern of pixel 0 (reference.cpp): one stratified set of samples
    // over the light, shared by every pixel, as a shadow map per sample requires.
    const uint32_t pattern = mixBits(0u ^ mixBits(settings_.seed + 0x9e3779b9u));
    sampleFrusta_.resize(sampleCount_);
    auto* data = static_cast<render::ShadowMapData*>(sampleMaps_.mapped());
    for (uint32_t s = 0; s < sampleCount_; ++s) {
        // ShadowMap::update throws if a sample's light needs another face count; by
        // construction (sampleLight) it never does.
        shape_.update(sampleLight(light, sampler.fixedSample(stratifiedSample(s, sampleCount_, pattern))), sceneBounds);
        sampleFrusta_[s] = shape_.frusta();
        std::memcpy(&data[s], &shape_.data(), sizeof(render::ShadowMapData));
    }
}

void RasterReference::registerPasses(graph::RenderGraph& graph, const plugin::LightPassIo& io)
{
    // Per pixel: the weighted sum of lit compares and the sum of weights (RG32F: a sum of
    // up to 65536 ones is exact in fp32). Each batch reads the sums so far and writes
    // them with its samples added into an image of its own: the graph orders the batches
    // by that chain (passes that read and write one image would have no order among them)
    // and aliases the images, of which two are alive at a time.
    std::string previous;
    for (size_t b = 0; b < batches_.size(); ++b) {
        const Batch batch = batches_[b];
        const std::string maps = io.local(fmt::format("sample_maps{}", b));
        const std::string sums = io.local(fmt::format("sums{}", b));
        graph.declareImage({maps, gridColumns_ * shape_.atlasWidth(), batch.rows * shape_.atlasHeight(),
                            render::kShadowDepthFormat});
        graph.declareImage({sums, width_, height_, VK_FORMAT_R32G32_SFLOAT});
        graph.addPass(maps, graph::QueueKind::Graphics)
            .write(maps, graph::Usage::DepthAttachment)
            .execute([this, maps, batch](graph::PassContext& pass) {
                std::vector<render::ShadowMapPlacement> placements;
                placements.reserve(batch.count);
                for (uint32_t k = 0; k < batch.count; ++k) {
                    const uint32_t s = batch.first + k;
                    placements.push_back({sampleFrusta_[s],
                                          {int32_t((k % gridColumns_) * shape_.atlasWidth()),
                                           int32_t((k / gridColumns_) * shape_.atlasHeight())},
                                          s * render::kMaxShadowFaces});
                }
                shape_.recordDepthMaps(pass, maps, kDepthBias, placements);
            });
        graph::PassBuilder accumulate = graph.addPass(io.local(fmt::format("accumulate{}", b)), graph::QueueKind::Compute);
        plugin::readGBuffer(accumulate, io.gbuffer);
        accumulate.read(maps, graph::Usage::Sampled)
            .write(sums, graph::Usage::Storage);
        if (!previous.empty()) accumulate.read(previous, graph::Usage::Storage);
        accumulate.execute([this, io, maps, previous, sums, batch](graph::PassContext& pass) {
            recordAccumulate(pass, io, maps, previous, sums, batch);
        });
        previous = sums;
    }
    graph.addPass(io.local("resolve"), graph::QueueKind::Compute)
        .read(previous, graph::Usage::Storage)
        .write(io.visibility, graph::Usage::Storage)
        .execute([this, io, previous](graph::PassContext& pass) { recordResolve(pass, io, previous); });
}

void RasterReference::recordAccumulate(const graph::PassContext& pass, const plugin::LightPassIo& io,
                                       const std::string& maps, const std::string& previous, const std::string& sums,
                                       const Batch& batch) const
{
    VkCommandBuffer cmd = pass.cmd();
    const gpu::Image& out = pass.image(sums);
    const gpu::Pipeline& pipeline = previous.empty() ? accumulateFirst_ : accumulate_;
    pipeline.bind(cmd);
    gpu::DescriptorPush descriptors;
    plugin::bindGBuffer(pass, io.gbuffer, descriptors);
    descriptors.sampledImage("sampleMaps", pass.image(maps), compareSampler_, pass.layout(maps))
        .storageImage("sums", out)
        .storageBuffer("shadowMapArray", sampleMaps_);
    if (!previous.empty()) descriptors.storageImage("previousSums", pass.image(previous));
    descriptors.push(context_, cmd, pipeline);
    AccumulatePush push;
    if (light_.type == scene::LightType::Point && light_.radiusWorld > 0.0f)
        push.sphere = glm::vec4(light_.position, light_.radiusWorld);
    push.firstSample = batch.first;
    push.sampleCount = batch.count;
    push.gridColumns = gridColumns_;
    push.gridRows = batch.rows;
    pipeline.pushConstants(cmd, &push, sizeof(push));
    pipeline.dispatchOver(cmd, out);
}

void RasterReference::recordResolve(const graph::PassContext& pass, const plugin::LightPassIo& io,
                                    const std::string& sums) const
{
    VkCommandBuffer cmd = pass.cmd();
    const gpu::Image& out = pass.image(io.visibility);
    resolve_.bind(cmd);
    gpu::DescriptorPush()
        .storageImage("sums", pass.image(sums))
        .storageImage("visibilityOut", out)
        .push(context_, cmd, resolve_);
    resolve_.dispatchOver(cmd, out);
}

} // namespace penumbra::reference
