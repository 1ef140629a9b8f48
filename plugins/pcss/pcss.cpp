// Percentage-closer soft shadows (Fernando 2005, "Percentage-Closer Soft Shadows",
// SIGGRAPH sketch; README.md next to this file): the engine's shadow map
// (render/ShadowMap.h), then one compute pass that, per pixel, searches the map for
// blockers over the region the light covers as seen from the receiver, estimates the
// penumbra width from the average blocker distance, and filters that many texels of
// compares with a rotated Poisson disk (visibility.glsl, its visibility function).
#include "penumbra/gpu/Context.h"
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/gpu/Resources.h"
#include "penumbra/graph/PassContext.h"
#include "penumbra/graph/RenderGraph.h"
#include "penumbra/plugin/Plugin.h"
#include "penumbra/plugin/ShadowMapParams.h"
#include "penumbra/plugin/Technique.h"
#include "penumbra/plugin/VisibilityFunction.h"
#include "penumbra/render/ShadowMap.h"


#include <algorithm>
#include <cmath>
#include <iterator>
#include <string>

namespace penumbra::pcss {
namespace {

using plugin::ParamType;

// Parameter `bias_mode`, in ParamSpec choice order.
enum class BiasMode : uint32_t { ReceiverPlane, Slope };
constexpr const char* kBiasModeNames[] = {"receiver_plane", "slope"};

constexpr int kSamplesMin = 4, kSamplesMax = render::kPoissonDiskPoints;
const plugin::ParamSpec kParams[] = {
    plugin::shadowResolutionParam(2048, 16384),
    plugin::kLightSizeParam,
    {"blocker_samples", ParamType::Int, 16, kSamplesMin, kSamplesMax, "", "depth taps of the blocker search"},
    {"filter_samples", ParamType::Int, 32, kSamplesMin, kSamplesMax, "", "compares of the penumbra filter"},
    plugin::kernelLimitParam("max_search_radius", 0.0625,
                             "largest blocker-search radius, a fraction of the face's side (the light seen from the "
                             "receiver is clamped to it)"),
    plugin::kernelLimitParam("max_filter_radius", 0.0625,
                             "largest filter radius, a fraction of the face's side (the estimated penumbra is clamped "
                             "to it)"),
    {"bias_mode", ParamType::Enum, double(BiasMode::ReceiverPlane), 0, 0, "",
     "receiver_plane: every tap compares against the receiver's plane at that tap; slope: rasterizer slope bias",
     kBiasModeNames, uint32_t(std::size(kBiasModeNames))},
    plugin::kShadowDepthBiasParam,  // in every bias_mode
    plugin::slopeBiasParam("slope-scaled rasterizer depth bias factor; bias_mode slope only (it must cover the widest "
                           "filter)"),
};

struct Settings {
    uint32_t resolution = 2048;
    float lightSizeOverride = -1.0f;
    uint32_t blockerSamples = 16;
    uint32_t filterSamples = 32;
    float maxSearchTexels = 128.0f;  // the limits' fractions of the face, in its texels
    float maxFilterTexels = 128.0f;
    BiasMode bias = BiasMode::ReceiverPlane;
    float depthBias = 4.0f;
    float slopeBias = 2.0f;
};

Settings readSettings(const plugin::ParamValues& params)
{
    Settings s;
    s.resolution = uint32_t(params.getInt("resolution"));
    s.lightSizeOverride = plugin::lightSizeOverride(params, "pcss");
    s.blockerSamples = uint32_t(params.getInt("blocker_samples"));
    s.filterSamples = uint32_t(params.getInt("filter_samples"));
    s.maxSearchTexels = plugin::kernelLimitTexels(params.getFloat("max_search_radius"), s.resolution);
    s.maxFilterTexels = plugin::kernelLimitTexels(params.getFloat("max_filter_radius"), s.resolution);
    s.bias = BiasMode(params.getEnumIndex("bias_mode"));
    s.depthBias = params.getFloat("depth_bias");
    s.slopeBias = params.getFloat("slope_bias");
    return s;
}

// visibility.glsl's PcssLight (std140): what follows the light.
struct PcssLight {
    float lightSize = 0.0f;  // render::softShadowLightSize()
    float ownShape = 1.0f;   // 1: the light's own shape (penumbra_estimate.glsl shadowLightExtent); 0: light_size's square
    float pad[2] = {};
};
static_assert(sizeof(PcssLight) == 16);

class PcssShadow final : public plugin::Technique {
public:
    explicit PcssShadow(const plugin::TechniqueSetup& setup);

    void update(const scene::Light& light, const scene::Aabb& sceneBounds) override;
    void registerPasses(graph::RenderGraph& graph, const plugin::LightPassIo& io) override;

private:
    bool usesReceiverPlane() const { return settings_.bias == BiasMode::ReceiverPlane; }
    // The culling footprint (and, with slope bias, the own-depth taps) of this light's
    // kernels, after each refit of the map.
    void fitFootprint();
    void setLightSize(float lightSize);

    gpu::Context& context_;
    const Settings settings_;
    render::ShadowMap shadowMap_;
    plugin::VisibilityFunction visibility_;
    gpu::Sampler compareSampler_;
    gpu::Sampler depthSampler_;
    gpu::Buffer lightBuffer_;  // PcssLight
    float lightSize_ = 0.0f;
};

PcssShadow::PcssShadow(const plugin::TechniqueSetup& setup)
    : context_(setup.context),
      settings_(readSettings(setup.params)),
      // Taps reach the kernel limits past a cube edge: read in the receiver's own face.
      shadowMap_(setup, settings_.resolution, "pcss",
                 render::kernelGuardTexels(std::max(settings_.maxSearchTexels, settings_.maxFilterTexels),
                                           settings_.resolution))
{
    std::vector<gpu::ShaderDefine> defines = {
        {"RECEIVER_BIAS",
         std::to_string(uint32_t(usesReceiverPlane() ? render::ReceiverBias::Plane : render::ReceiverBias::None))}};
    defines.push_back({"BLOCKER_SAMPLES", std::to_string(settings_.blockerSamples)});
    defines.push_back({"FILTER_SAMPLES", std::to_string(settings_.filterSamples)});
    defines.push_back(plugin::floatDefine("MAX_SEARCH_TEXELS", settings_.maxSearchTexels));
    defines.push_back(plugin::floatDefine("MAX_FILTER_TEXELS", settings_.maxFilterTexels));
    std::ranges::copy(shadowMap_.shaderDefines(), std::back_inserter(defines));
    // 8 x 8 tiles: the search and the filter read a disk of the map around each receiver.
    visibility_ = plugin::VisibilityFunction(setup, "visibility.glsl", defines, 8, 8);
    lightBuffer_ = gpu::Buffer(context_, sizeof(PcssLight), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT, true, setup.local("light"));

    // Every tap reads one texel (at its centre): the search averages texel depths, the
    // filter counts texel compares. Taps never leave the map (the shader clamps them).
    compareSampler_ = render::createShadowCompareSampler(context_);
    depthSampler_ = render::createShadowDepthSampler(context_);
    setLightSize(render::softShadowLightSize(setup.light, settings_.lightSizeOverride));
    // Only the search and the filter read the map, all within the footprint: with
    // receiver-mask culling the depth pass clears and draws only what they can read.
    shadowMap_.setReadByLookupsOnly(true);
}

void PcssShadow::update(const scene::Light& light, const scene::Aabb& sceneBounds)
{
    shadowMap_.update(light, sceneBounds);
    setLightSize(render::softShadowLightSize(light, settings_.lightSizeOverride));
}

void PcssShadow::setLightSize(float lightSize)
{
    lightSize_ = lightSize;
    auto* light = static_cast<PcssLight*>(lightBuffer_.mapped());
    light->lightSize = lightSize;
    light->ownShape = settings_.lightSizeOverride < 0.0f ? 1.0f : 0.0f;
    fitFootprint();
}

void PcssShadow::fitFootprint()
{
    // The search and the filter reach no further than the light's size allows on this map,
    // nor past their limits.
    const float footprint =
        shadowMap_.setSoftShadowFootprint(lightSize_, std::max(settings_.maxSearchTexels, settings_.maxFilterTexels));
    // Slope bias: the search and the filter compare each tap with the receiver's own depth.
    if (settings_.bias == BiasMode::Slope) shadowMap_.setOwnDepthCompare(int32_t(std::ceil(footprint)));
}

void PcssShadow::registerPasses(graph::RenderGraph& graph, const plugin::LightPassIo& io)
{
    const std::string map = io.local("shadow_map");
    shadowMap_.addDepthPass(graph, map,
                            {settings_.depthBias, settings_.bias == BiasMode::Slope ? settings_.slopeBias : 0.0f, 0.0f});

    // The search reads the map's depths, the filter compares with them.
    const auto bind = [this, map](const graph::PassContext& pass, gpu::DescriptorPush& descriptors) {
        descriptors.sampledImage("shadowCompare", pass.image(map), compareSampler_, pass.layout(map))
            .sampledImage("shadowDepth", pass.image(map), depthSampler_, pass.layout(map))
            .storageBuffer("shadowMapBuffer", shadowMap_.buffer())
            .uniformBuffer("pcssLight", lightBuffer_);
    };
    plugin::addVisibilityFunction(graph, io, visibility_, {map}, bind);
}

} // namespace
} // namespace penumbra::pcss

PENUMBRA_DEFINE_PLUGIN("pcss", "1.0.0",
                       "percentage-closer soft shadows: blocker search, penumbra estimate, Poisson-disk filter "
                       "(Fernando 2005)",
                       penumbra::pcss::kParams, penumbra::pcss::PcssShadow)
