// Variance soft shadow mapping (Yang, Dong, Feng, Seidel and Kautz 2010; README.md next
// to this file): the PCSS framework with the blocker search and the filter read from a
// summed-area table of the map's moments instead of point samples, and the kernels
// subdivided where the variance test cannot decide (the "non-planarity" problem).
// Passes (paper Algorithm 1): the engine's shadow map (render/ShadowMap.h), its
// summed-area table (sat.comp, sat.glsl), its min-max hierarchy (hsm.comp, hsm.glsl),
// and the per-pixel visibility (visibility.comp). The table (an image) and the
// hierarchy (a buffer) are transient graph resources.
#include "penumbra/core/Error.h"
#include "penumbra/gpu/Barrier.h"
#include "penumbra/gpu/Context.h"
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/graph/PassContext.h"
#include "penumbra/graph/RenderGraph.h"
#include "penumbra/plugin/ComputePipeline.h"
#include "penumbra/plugin/DebugViews.h"
#include "penumbra/plugin/Plugin.h"
#include "penumbra/plugin/ShadowMapParams.h"
#include "penumbra/plugin/Technique.h"
#include "penumbra/plugin/VisibilityPass.h"
#include "penumbra/render/ShadowMap.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <optional>
#include <string>
#include <vector>

namespace penumbra::vssm {
namespace {

using plugin::ParamType;

// Parameter `subdivision`, in ParamSpec choice order (§6.3: mixed is the paper's).
enum class Subdivision : uint32_t { None, Uniform, Adaptive, Mixed };
constexpr const char* kSubdivisionNames[] = {"none", "uniform", "adaptive", "mixed"};
// visibility.comp's BLOCKER_SUBDIVISION / FILTER_SUBDIVISION values.
enum class Scheme : uint32_t { None = 0, Uniform = 1, Adaptive = 2 };

// Parameter `bias_mode`.
enum class BiasMode : uint32_t { ReceiverPlane, Slope };
constexpr const char* kBiasModeNames[] = {"receiver_plane", "slope"};

// The debug images the debug_views pass writes (visibility.comp DEBUG_IMAGES), each
// io.local(name): requested by name (penumbra render --debug-image light0.vssm.kernel),
// else the pass is culled and costs nothing.
constexpr plugin::DebugImage kDebugImages[] = {
    {"kernel", "kernelOut"}, {"classification", "classificationOut"}, {"subkernels", "subkernelsOut"}};

constexpr int kMaxTreeHeight = 5;  // visibility.comp clamps to it (4^5 leaves)

const plugin::ParamSpec kParams[] = {
    {"resolution", ParamType::Int, 1024, 16, 8192, "texels",
     "shadow-map texels per side of each face (point, rect and disk lights: six faces in a 3 x 2 atlas); the "
     "summed-area table takes 16 bytes per texel"},
    plugin::kLightSizeParam,
    {"subdivision", ParamType::Enum, double(Subdivision::Mixed), 0, 0, "",
     "none: one box per kernel, non-planar kernels lit (SAVSM-like); uniform: m x m blocker and n x n filter "
     "sub-kernels; adaptive: quad-trees of height H for both; mixed: m x m blocker, quad-tree filter (paper 6.3)",
     kSubdivisionNames, uint32_t(std::size(kSubdivisionNames))},
    {"blocker_subdivisions", ParamType::Int, 5, 1, 16, "", "m: sub-kernels per side of the blocker search (uniform)"},
    {"filter_subdivisions", ParamType::Int, 8, 1, 16, "", "n: sub-kernels per side of the filter (uniform)"},
    {"tree_height", ParamType::Int, 3, 0, kMaxTreeHeight, "", "H: levels of the adaptive quad-tree (4^H leaves)"},
    plugin::kernelLimitParam("max_search_radius", 0.0625, "largest blocker-search half-width, a fraction of the face's side"),
    plugin::kernelLimitParam("max_filter_radius", 0.0625,
                             "largest penumbra-filter half-width, a fraction of the face's side"),
    {"lit_variance", ParamType::Float, 1e-4, 0, 1, "r^2",
     "Threshold of Algorithm 2: a sub-kernel behind the receiver with a variance below lit_variance r^2 is lit "
     "(r: the scene's bounding radius; paper 6.5)"},
    {"contact_epsilon", ParamType::Float, 0.01, 0, 1, "r",
     "blockers within contact_epsilon r of the receiver get 3 x 3 jittered bilinear PCF (paper 6.4)"},
    {"bias_mode", ParamType::Enum, double(BiasMode::ReceiverPlane), 0, 0, "",
     "receiver_plane: each sub-kernel and tap compares against the receiver's plane there; slope: the receiver's "
     "depth and the rasterizer's slope bias",
     kBiasModeNames, uint32_t(std::size(kBiasModeNames))},
    plugin::kShadowDepthBiasParam,  // in every bias_mode
    plugin::slopeBiasParam("slope-scaled rasterizer depth bias factor; bias_mode slope only"),
};

struct Settings {
    uint32_t resolution = 1024;
    float lightSizeOverride = -1.0f;
    Subdivision subdivision = Subdivision::Mixed;
    int blockerSubdivisions = 5;
    int filterSubdivisions = 8;
    int treeHeight = 3;
    float maxSearchTexels = 64.0f;  // the limits' fractions of the face, in its texels
    float maxFilterTexels = 64.0f;
    float litVariance = 1e-4f;
    float contactEpsilon = 0.01f;
    BiasMode bias = BiasMode::ReceiverPlane;
    float depthBias = 4.0f;
    float slopeBias = 2.0f;

    Scheme blockerScheme() const
    {
        switch (subdivision) {
        case Subdivision::None: return Scheme::None;
        case Subdivision::Adaptive: return Scheme::Adaptive;
        default: return Scheme::Uniform;
        }
    }
    Scheme filterScheme() const
    {
        switch (subdivision) {
        case Subdivision::None: return Scheme::None;
        case Subdivision::Uniform: return Scheme::Uniform;
        default: return Scheme::Adaptive;
        }
    }
};

Settings readSettings(const plugin::ParamValues& params)
{
    Settings s;
    s.resolution = uint32_t(params.getInt("resolution"));
    s.lightSizeOverride = plugin::lightSizeOverride(params, "vssm");
    s.subdivision = Subdivision(params.getEnumIndex("subdivision"));
    s.blockerSubdivisions = params.getInt("blocker_subdivisions");
    s.filterSubdivisions = params.getInt("filter_subdivisions");
    s.treeHeight = params.getInt("tree_height");
    s.maxSearchTexels = plugin::kernelLimitTexels(params.getFloat("max_search_radius"), s.resolution);
    s.maxFilterTexels = plugin::kernelLimitTexels(params.getFloat("max_filter_radius"), s.resolution);
    s.litVariance = params.getFloat("lit_variance");
    s.contactEpsilon = params.getFloat("contact_epsilon");
    s.bias = BiasMode(params.getEnumIndex("bias_mode"));
    s.depthBias = params.getFloat("depth_bias");
    s.slopeBias = params.getFloat("slope_bias");
    return s;
}

// The most sub-kernels one scheme visits in one kernel.
int maxNodes(Scheme scheme, int perSide, int height)
{
    switch (scheme) {
    case Scheme::None: return 1;
    case Scheme::Uniform: return perSide * perSide;
    case Scheme::Adaptive: return ((1 << (2 * (height + 1))) - 1) / 3;  // 1 + 4 + ... + 4^H
    }
    return 1;
}

struct VisibilityPush {
    glm::ivec2 atlasSize{0};
    float lightSize = 0.0f;
    float maxSearchTexels = 0.0f;
    float maxFilterTexels = 0.0f;
    float sceneRadius = 0.0f;
    float litVariance = 0.0f;
    float contactEpsilon = 0.0f;
    int32_t blockerSubdivisions = 1;
    int32_t filterSubdivisions = 1;
    int32_t treeHeight = 0;
    float subkernelScale = 0.0f;
    float ownShape = 1.0f;  // 1: the light's own shape (penumbra_estimate.glsl shadowLightExtent); 0: light_size's square
};
static_assert(sizeof(VisibilityPush) == 52);

struct SatPush {
    glm::ivec2 size{0};
    int32_t vertical = 0;
};

struct HsmPush {
    glm::ivec2 size{0};
    int32_t level = 0;
};

// The min-max hierarchy's levels (hsm.glsl): down to one texel, level 0 (the depth
// map itself) included.
int hsmLevelCount(uint32_t width, uint32_t height)
{
    int levels = 1;
    while (((width + (1u << (levels - 1)) - 1) >> (levels - 1)) > 1 ||
           ((height + (1u << (levels - 1)) - 1) >> (levels - 1)) > 1)
        ++levels;
    return levels;
}

// The image of levels 1 and up (hsm.glsl hsmLevelOrigin): level 1 at the origin, the
// others in a column to its right. Never wider or taller than the atlas.
glm::uvec2 hsmImageSize(uint32_t width, uint32_t height)
{
    const auto side = [](uint32_t texels, int level) { return (texels + (1u << level) - 1) >> level; };
    uint32_t column = 0;
    for (int level = 2; level < hsmLevelCount(width, height); ++level) column += side(height, level);
    return {side(width, 1) + side(width, 2), std::max(side(height, 1), column)};
}

// The bytes of a texel of the summed-area table (RGBA32UI, sat.glsl).
constexpr VkDeviceSize kSatTexelBytes = 16;

class VssmShadow final : public plugin::Technique {
public:
    explicit VssmShadow(const plugin::TechniqueSetup& setup);

    void update(const scene::Light& light, const scene::Aabb& sceneBounds) override;
    void registerPasses(graph::RenderGraph& graph, const plugin::LightPassIo& io) override;

private:
    void checkDevice() const;
    // The culling footprint of this light's kernels, after each refit of the map.
    void fitFootprint();
    void recordSat(const graph::PassContext& pass, const std::string& map, const std::string& sat) const;
    void recordHsm(const graph::PassContext& pass, const std::string& map, const std::string& hsm) const;
    void bindVisibility(const graph::PassContext& pass, gpu::DescriptorPush& descriptors, const std::string& map,
                        const std::string& sat, const std::string& hsm, const gpu::Pipeline& pipeline) const;
    glm::ivec2 atlasSize() const { return {int(shadowMap_.atlasWidth()), int(shadowMap_.atlasHeight())}; }

    gpu::Context& context_;
    const Settings settings_;
    render::ShadowMap shadowMap_;
    gpu::Pipeline sat_;
    gpu::Pipeline hsm_;
    gpu::Pipeline visibility_;
    // The visibility shader with DEBUG_IMAGES, writing the debug images.
    std::optional<plugin::DebugViewPass> debugViews_;
    gpu::Sampler compareSampler_;
    gpu::Sampler depthSampler_;
    float lightSize_ = 0.0f;
    float sceneRadius_ = 0.0f;
};

float boundingRadius(const scene::Aabb& bounds)
{
    const glm::vec3 extent = bounds.max - bounds.min;
    const float r = 0.5f * std::sqrt(glm::dot(extent, extent));
    return std::isfinite(r) ? r : 0.0f;  // an empty scene's inverted box: no threshold
}

VssmShadow::VssmShadow(const plugin::TechniqueSetup& setup)
    : context_(setup.context),
      settings_(readSettings(setup.params)),
      // Kernels reach the limits past a cube edge: boxes there lie in the receiver's face.
      shadowMap_(setup, settings_.resolution, "vssm",
                 render::kernelGuardTexels(std::max(settings_.maxSearchTexels, settings_.maxFilterTexels),
                                           settings_.resolution))
{
    checkDevice();
    sat_ = plugin::createComputePipeline(setup, "sat", "sat.comp", shadowMap_.shaderDefines(), sizeof(SatPush));
    hsm_ = plugin::createComputePipeline(setup, "hsm", "hsm.comp", shadowMap_.shaderDefines(), sizeof(HsmPush));

    std::vector<gpu::ShaderDefine> defines = {
        {"RECEIVER_BIAS", std::to_string(uint32_t(settings_.bias == BiasMode::ReceiverPlane ? render::ReceiverBias::Plane
                                                                                            : render::ReceiverBias::None))},
        {"BLOCKER_SUBDIVISION", std::to_string(uint32_t(settings_.blockerScheme()))},
        {"FILTER_SUBDIVISION", std::to_string(uint32_t(settings_.filterScheme()))}};
    std::ranges::copy(shadowMap_.shaderDefines(), std::back_inserter(defines));
    visibility_ = plugin::createComputePipeline(setup, "visibility", "visibility.comp", defines, sizeof(VisibilityPush));
    defines.push_back({"DEBUG_IMAGES", "1"});
    debugViews_.emplace(setup, plugin::computePipelineDesc(setup, "debug_views", "visibility.comp", defines,
                                                           sizeof(VisibilityPush)));

    compareSampler_ = render::createShadowCompareSampler(context_);
    depthSampler_ = render::createShadowDepthSampler(context_);
    lightSize_ = render::softShadowLightSize(setup.light, settings_.lightSizeOverride);
    sceneRadius_ = boundingRadius(setup.sceneBounds);
    fitFootprint();
}

// The table needs 64-bit integers in shaders, and its box queries fp64 (sat.glsl); both
// are optional Vulkan features, and so is the RG32F storage format of the hierarchy. The
// table is the largest single allocation (16 bytes a texel of the atlas): it must fit
// the device's largest one. (Image sizes: the depth atlas is checked by ShadowMap, and
// neither image is larger than it.)
void VssmShadow::checkDevice() const
{
    VkPhysicalDeviceFeatures features{};
    vkGetPhysicalDeviceFeatures(context_.physicalDevice(), &features);
    if (!features.shaderInt64 || !features.shaderFloat64) {
        throw ConfigError(fmt::format("vssm: this device lacks {} (the summed-area table is 64-bit fixed point, "
                                      "plugins/vssm/sat.glsl); choose another technique or device",
                                      !features.shaderInt64 ? "shaderInt64" : "shaderFloat64"));
    }
    if (!features.shaderStorageImageExtendedFormats) {
        throw ConfigError("vssm: this device lacks shaderStorageImageExtendedFormats (the min-max hierarchy is an "
                          "RG32F storage image, plugins/vssm/hsm.glsl); choose another technique or device");
    }
    const VkDeviceSize largest = context_.maxMemoryAllocationSize();
    const VkDeviceSize texels = VkDeviceSize(shadowMap_.atlasWidth()) * shadowMap_.atlasHeight();
    if (texels * kSatTexelBytes > largest) {
        // The atlas holds `faces` faces of faceTexels() (the resolution and its guard
        // texels) a side: the largest face that fits, less the same guard, is the
        // largest resolution (the guard never grows with a lower one).
        const VkDeviceSize face = VkDeviceSize(shadowMap_.faceTexels()) * shadowMap_.faceTexels();
        const VkDeviceSize faces = texels / face;
        const auto largestFace = VkDeviceSize(std::floor(std::sqrt(
            double(largest / kSatTexelBytes / faces))));
        const VkDeviceSize guards = shadowMap_.faceTexels() - settings_.resolution;
        const VkDeviceSize fits = largestFace > guards ? largestFace - guards : 0;
        throw ConfigError(fmt::format("vssm: resolution: {} texels per face need a {} MiB summed-area table, more than "
                                      "this device's largest allocation ({} MiB, maxMemoryAllocationSize); use at "
                                      "most {}",
                                      settings_.resolution, (texels * kSatTexelBytes) >> 20,
                                      largest >> 20, fits));
    }
}

void VssmShadow::update(const scene::Light& light, const scene::Aabb& sceneBounds)
{
    shadowMap_.update(light, sceneBounds);
    lightSize_ = render::softShadowLightSize(light, settings_.lightSizeOverride);
    sceneRadius_ = boundingRadius(sceneBounds);
    fitFootprint();
}

void VssmShadow::fitFootprint()
{
    // The kernels reach no further than the light's size allows on this map, nor past
    // their limits (the 0.5-texel least kernel is inside the footprint's extra texel).
    shadowMap_.setSoftShadowFootprint(lightSize_, std::max(settings_.maxSearchTexels, settings_.maxFilterTexels));
}

void VssmShadow::registerPasses(graph::RenderGraph& graph, const plugin::LightPassIo& io)
{
    const std::string map = io.local("shadow_map");
    shadowMap_.addDepthPass(graph, map,
                            {settings_.depthBias, settings_.bias == BiasMode::Slope ? settings_.slopeBias : 0.0f, 0.0f});

    const uint32_t width = shadowMap_.atlasWidth(), height = shadowMap_.atlasHeight();
    const std::string sat = io.local("sat"), hsm = io.local("hsm");
    graph.declareImage({sat, width, height, VK_FORMAT_R32G32B32A32_UINT});
    const glm::uvec2 hsmSize = hsmImageSize(width, height);
    graph.declareImage({hsm, hsmSize.x, hsmSize.y, VK_FORMAT_R32G32_SFLOAT});
    graph.addPass(sat, graph::QueueKind::Compute)
        .read(map, graph::Usage::Sampled)
        .write(sat, graph::Usage::Storage)
        .dependsOn(io.lightState)
        .execute([this, map, sat](graph::PassContext& pass) { recordSat(pass, map, sat); });
    graph.addPass(hsm, graph::QueueKind::Compute)
        .read(map, graph::Usage::Sampled)
        .write(hsm, graph::Usage::Storage)
        .dependsOn(io.lightState)
        .execute([this, map, hsm](graph::PassContext& pass) { recordHsm(pass, map, hsm); });

    const auto bind = [this, map, sat, hsm](const graph::PassContext& pass, gpu::DescriptorPush& descriptors) {
        bindVisibility(pass, descriptors, map, sat, hsm, visibility_);
    };
    plugin::addVisibilityPass(graph, io, visibility_, bind)
        .read(map, graph::Usage::Sampled)
        .read(sat, graph::Usage::Storage)
        .read(hsm, graph::Usage::Storage)
        .dependsOn(io.lightState)
        .dependsOn(io.cameraState);

    // The debug views, culled unless one of their images is requested.
    const auto bindDebug = [this, map, sat, hsm](const graph::PassContext& pass, gpu::DescriptorPush& descriptors,
                                                 const gpu::Pipeline& pipeline) {
        bindVisibility(pass, descriptors, map, sat, hsm, pipeline);
    };
    debugViews_->addOverGBuffer(graph, io, io.local("debug_views"), kDebugImages, bindDebug)
        .read(map, graph::Usage::Sampled)
        .read(sat, graph::Usage::Storage)
        .read(hsm, graph::Usage::Storage);
}

void VssmShadow::recordSat(const graph::PassContext& pass, const std::string& map, const std::string& sat) const
{
    VkCommandBuffer cmd = pass.cmd();
    sat_.bind(cmd);
    gpu::DescriptorPush()
        .sampledImage("shadowDepth", pass.image(map), depthSampler_, pass.layout(map))
        .storageImage("satImage", pass.image(sat))
        .storageBuffer("shadowMapBuffer", shadowMap_.buffer())
        .push(context_, cmd, sat_);
    const glm::ivec2 size = atlasSize();
    SatPush push{size, 0};
    sat_.pushConstants(cmd, &push, sizeof(push));
    sat_.dispatchOver(cmd, uint32_t(size.y));  // one invocation per row
    gpu::memoryBarrier(cmd, gpu::access::kComputeStorageWrite, gpu::access::kComputeStorageReadWrite);
    push.vertical = 1;
    sat_.pushConstants(cmd, &push, sizeof(push));
    sat_.dispatchOver(cmd, uint32_t(size.x));  // one per column
}

void VssmShadow::recordHsm(const graph::PassContext& pass, const std::string& map, const std::string& hsm) const
{
    VkCommandBuffer cmd = pass.cmd();
    hsm_.bind(cmd);
    gpu::DescriptorPush()
        .sampledImage("shadowDepth", pass.image(map), depthSampler_, pass.layout(map))
        .storageImage("hsmImage", pass.image(hsm))
        .storageBuffer("shadowMapBuffer", shadowMap_.buffer())
        .push(context_, cmd, hsm_);
    const glm::ivec2 size = atlasSize();
    const int levels = hsmLevelCount(uint32_t(size.x), uint32_t(size.y));
    for (int level = 1; level < levels; ++level) {
        if (level > 1) gpu::memoryBarrier(cmd, gpu::access::kComputeStorageWrite, gpu::access::kComputeStorageReadWrite);
        const HsmPush push{size, level};
        hsm_.pushConstants(cmd, &push, sizeof(push));
        const glm::ivec2 texels = (size + (1 << level) - 1) >> level;
        hsm_.dispatchOver(cmd, uint32_t(texels.x), uint32_t(texels.y));
    }
}

void VssmShadow::bindVisibility(const graph::PassContext& pass, gpu::DescriptorPush& descriptors,
                                const std::string& map, const std::string& sat, const std::string& hsm,
                                const gpu::Pipeline& pipeline) const
{
    descriptors.sampledImage("shadowCompare", pass.image(map), compareSampler_, pass.layout(map))
        .storageBuffer("shadowMapBuffer", shadowMap_.buffer())
        .sampledImage("shadowDepth", pass.image(map), depthSampler_, pass.layout(map))
        .storageImage("satImage", pass.image(sat))
        .storageImage("hsmImage", pass.image(hsm));
    const int most = maxNodes(settings_.blockerScheme(), settings_.blockerSubdivisions, settings_.treeHeight) +
                     maxNodes(settings_.filterScheme(), settings_.filterSubdivisions, settings_.treeHeight);
    const VisibilityPush push{atlasSize(),
                              lightSize_,
                              settings_.maxSearchTexels,
                              settings_.maxFilterTexels,
                              sceneRadius_,
                              settings_.litVariance,
                              settings_.contactEpsilon,
                              settings_.blockerSubdivisions,
                              settings_.filterSubdivisions,
                              settings_.treeHeight,
                              1.0f / float(std::max(most, 1)),
                              settings_.lightSizeOverride < 0.0f ? 1.0f : 0.0f};
    pipeline.pushConstants(pass.cmd(), &push, sizeof(push));
}

} // namespace
} // namespace penumbra::vssm

PENUMBRA_DEFINE_PLUGIN("vssm", "1.0.0",
                       "variance soft shadow mapping: summed-area table of 64-bit moments, min-max hierarchy, eq. 4 "
                       "blocker depth, uniform and adaptive kernel subdivision (Yang et al. 2010)",
                       penumbra::vssm::kParams, penumbra::vssm::VssmShadow)
