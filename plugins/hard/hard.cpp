// The hard shadow-map technique (README.md next to this file): the engine's shadow map
// (render/ShadowMap.h: one frustum for spot and directional lights, six cube faces in a
// 3 x 2 atlas for point, rect and disk lights, seen from their centre), then a compute
// visibility function that compares a G-buffer position with the map (visibility.glsl:
// the engine runs it as the light's visibility pass, or inside shading where nothing else
// reads V_l). Bias modes and filters are parameters; the filter and receiver-side bias
// pick a shader variant (visibility_pass.h), the constant and slope-scaled bias are the
// rasterizer's.
#include "visibility_pass.h"

#include "penumbra/core/Error.h"
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
#include <vector>

namespace penumbra::hard {
namespace {

using plugin::ParamType;

// Names, defaults and ranges of the first four are what shipped configs and the config
// schema use: keep them.
const plugin::ParamSpec kParams[] = {
    plugin::shadowResolutionParam(2048, 16384),
    plugin::kShadowDepthBiasParam,  // in every bias_mode
    plugin::slopeBiasParam("slope-scaled depth bias factor (rasterizer), per texel of the filter's width; bias_mode "
                           "slope only"),
    plugin::kBiasClampParam,
    {"bias_mode", ParamType::Enum, double(BiasMode::Slope), 0, 0, "",
     "constant: depth_bias only; slope: plus slope_bias; normal_offset: receiver moved along its normal; "
     "receiver_plane: per-tap depth from the receiver's plane",
     kBiasModeNames, uint32_t(std::size(kBiasModeNames))},
    {"normal_offset", ParamType::Float, 1.0, 0, 64, "texels",
     "bias_mode normal_offset: offset along the normal in shadow-map texels at the receiver, per texel of the "
     "filter's width, times sin(angle to the light)"},
    {"filter", ParamType::Enum, double(Filter::None), 0, 0, "",
     "none: one compare; pcf: pcf_kernel^2 box; poisson: poisson_samples on a disk of filter_radius; "
     "bilinear: 2 x 2 compare with bilinear weights",
     kFilterNames, uint32_t(std::size(kFilterNames))},
    plugin::oddKernelParam("pcf_kernel", 3, kPcfKernelMax, "filter pcf: taps per side of the box, odd (centred on the receiver)"),
    {"poisson_samples", ParamType::Int, 16, kPoissonSamplesMin, kPoissonSamplesMax, "",
     "filter poisson: taps on the disk"},
    {"filter_radius", ParamType::Float, 1.5, 0.5, 32, "texels", "filter poisson: disk radius"},
};

struct Settings {
    uint32_t resolution = 2048;
    float depthBias = 4.0f;
    float slopeBias = 2.0f;
    float biasClamp = 0.0f;
    float normalOffsetTexels = 1.0f;
    float filterRadiusTexels = 1.5f;
    VisibilityVariant variant;
};

// ParamValues has checked types and ranges; what remains is what a range cannot say.
Settings readSettings(const plugin::ParamValues& params)
{
    Settings s;
    s.resolution = uint32_t(params.getInt("resolution"));
    s.depthBias = params.getFloat("depth_bias");
    s.slopeBias = params.getFloat("slope_bias");
    s.biasClamp = params.getFloat("bias_clamp");
    s.normalOffsetTexels = params.getFloat("normal_offset");
    s.filterRadiusTexels = params.getFloat("filter_radius");
    s.variant.bias = BiasMode(params.getEnumIndex("bias_mode"));
    s.variant.filter = Filter(params.getEnumIndex("filter"));
    s.variant.pcfKernel = uint32_t(params.getInt("pcf_kernel"));
    s.variant.poissonSamples = uint32_t(params.getInt("poisson_samples"));
    return s;
}

// How many texels wide the compares of one lookup reach, per axis. Every tap compares
// the receiver's own depth with the map up to that far away, so the slope-scaled bias
// and the normal offset that keep a receiver free of self-shadowing grow with it:
// slope_bias and normal_offset are given for one compare (width 1) and scaled by this.
// Receiver plane bias compares each tap against the plane's depth there and needs none.
float footprintWidthTexels(const Settings& s)
{
    switch (s.variant.filter) {
    case Filter::None: return 1.0f;
    case Filter::Pcf: return float(s.variant.pcfKernel);
    case Filter::Poisson: return 2.0f * s.filterRadiusTexels + 1.0f;
    case Filter::Bilinear: return 2.0f;
    }
    return 1.0f;
}

class HardShadow final : public plugin::Technique {
public:
    explicit HardShadow(const plugin::TechniqueSetup& setup);
    HardShadow(const HardShadow&) = delete;
    HardShadow& operator=(const HardShadow&) = delete;

    void update(const scene::Light& light, const scene::Aabb& sceneBounds) override;
    void registerPasses(graph::RenderGraph& graph, const plugin::LightPassIo& io) override;

private:
    gpu::Context& context_;
    const Settings settings_;
    render::ShadowMap shadowMap_;
    plugin::VisibilityFunction visibility_;
    gpu::Sampler compareSampler_;
};

HardShadow::HardShadow(const plugin::TechniqueSetup& setup)
    : context_(setup.context),
      settings_(readSettings(setup.params)),
      // A filter's taps past a cube edge are read in the receiver's own face.
      shadowMap_(setup, settings_.resolution, "hard",
                 footprintWidthTexels(settings_) > 1.0f
                     ? render::kernelGuardTexels(0.5f * footprintWidthTexels(settings_), settings_.resolution)
                     : 0u)
{
    // The filter's half width, and the normal offset that moves the lookup (scaled by the
    // filter width, as in shadow_receiver.glsl).
    const float width = footprintWidthTexels(settings_);
    // Only the visibility pass's taps read the map, all within the footprint: with
    // receiver-mask culling the depth pass clears and draws only what they can read.
    shadowMap_.setReadByLookupsOnly(true);
    shadowMap_.setFootprint(0.5f * width +
                            (settings_.variant.bias == BiasMode::NormalOffset ? settings_.normalOffsetTexels * width : 0.0f));
    // Constant and slope bias compare every tap with the receiver's own depth; the taps
    // lie within half the filter's width of the receiver, so their texels within
    // ceil(width / 2 - 1/2) of its texel (none 0, pcf k: (k - 1) / 2, poisson ceil(radius),
    // bilinear 1).
    if (settings_.variant.bias == BiasMode::Constant || settings_.variant.bias == BiasMode::Slope)
        shadowMap_.setOwnDepthCompare(int32_t(std::ceil(0.5f * width - 0.5f)));
    std::vector<gpu::ShaderDefine> defines = visibilityDefines(settings_.variant);
    if (settings_.variant.offsetsAlongNormal())
        defines.push_back(plugin::floatDefine("NORMAL_OFFSET_TEXELS", settings_.normalOffsetTexels * width));
    if (settings_.variant.filter == Filter::Poisson)
        defines.push_back(plugin::floatDefine("FILTER_RADIUS_TEXELS", settings_.filterRadiusTexels));
    std::ranges::copy(shadowMap_.shaderDefines(), std::back_inserter(defines));
    visibility_ = plugin::VisibilityFunction(setup, "visibility.glsl", defines);

    // Nearest (one texel per compare) unless the hardware bilinear compare is wanted;
    // points outside the map never reach the sampler (the shader calls them lit).
    compareSampler_ = render::createShadowCompareSampler(context_, settings_.variant.samplerFilter());
}

void HardShadow::update(const scene::Light& light, const scene::Aabb& sceneBounds)
{
    shadowMap_.update(light, sceneBounds);
}

void HardShadow::registerPasses(graph::RenderGraph& graph, const plugin::LightPassIo& io)
{
    // Reversed-Z is the shadow map's business; here every term is "away from the light".
    // Only bias_mode slope scales with the caster's slope; normal_offset and
    // receiver_plane bias the receiver instead (shaders/common/shadow_receiver.glsl).
    const float slope =
        settings_.variant.bias == BiasMode::Slope ? settings_.slopeBias * footprintWidthTexels(settings_) : 0.0f;
    const std::string map = io.local("shadow_map");
    shadowMap_.addDepthPass(graph, map, {settings_.depthBias, slope, settings_.biasClamp});

    const auto bind = [this, map](const graph::PassContext& pass, gpu::DescriptorPush& descriptors) {
        descriptors.sampledImage("shadowMap", pass.image(map), compareSampler_, pass.layout(map))
            .storageBuffer("shadowMapBuffer", shadowMap_.buffer());
    };
    plugin::addVisibilityFunction(graph, io, visibility_, {map}, bind);
}

} // namespace
} // namespace penumbra::hard

PENUMBRA_DEFINE_PLUGIN("hard", "1.0.0",
                       "shadow map with constant, slope, normal-offset or receiver-plane bias and none, PCF, Poisson "
                       "or bilinear filtering",
                       penumbra::hard::kParams, penumbra::hard::HardShadow)
