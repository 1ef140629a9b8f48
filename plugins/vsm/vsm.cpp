// The variance shadow map family (README.md next to this file): VSM (Donnelly &
// Lauritzen 2006), EVSM (Lauritzen & McCool 2008) and ESM (Annen et al. 2008) as one
// technique with a `variant` parameter. The engine's shadow map (render/ShadowMap.h) is
// turned into a map of stored values (moments.comp), filtered by a separable blur
// (blur.comp, twice) or a mip chain (downsample.comp, once per level), and read per
// pixel by visibility.glsl (its visibility function). Every map after the depth map is a transient graph image,
// so the graph may alias the blur's scratch with the moments it no longer needs.
#include "penumbra/core/Error.h"
#include "penumbra/gpu/Context.h"
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/graph/PassContext.h"
#include "penumbra/graph/RenderGraph.h"
#include "penumbra/plugin/ComputePipeline.h"
#include "penumbra/plugin/Plugin.h"
#include "penumbra/plugin/Technique.h"
#include "penumbra/plugin/VisibilityFunction.h"
#include "penumbra/render/ShadowMap.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <iterator>
#include <string>
#include <vector>

namespace penumbra::vsm {
namespace {

using plugin::ParamType;

// Parameter `variant`, in ParamSpec choice order (moments.glsl VSM_VARIANT).
enum class Variant : uint32_t { Vsm, Evsm, Esm };
constexpr const char* kVariantNames[] = {"vsm", "evsm", "esm"};

// Parameter `moment_format`.
enum class MomentFormat : uint32_t { Auto, Rg32f, Rgba32f, Rgba16f };
constexpr const char* kMomentFormatNames[] = {"auto", "rg32f", "rgba32f", "rgba16f"};

// Each MomentFormat's image format, GLSL format qualifier and channel count (auto is
// resolved before use).
struct MomentStorage {
    VkFormat format;
    const char* glslName;
    uint32_t channels;
};
constexpr MomentStorage kMomentStorage[] = {{VK_FORMAT_UNDEFINED, "", 0},
                                            {VK_FORMAT_R32G32_SFLOAT, "rg32f", 2},
                                            {VK_FORMAT_R32G32B32A32_SFLOAT, "rgba32f", 4},
                                            {VK_FORMAT_R16G16B16A16_SFLOAT, "rgba16f", 4}};

// Parameter `filter` (visibility.glsl FILTER: gaussian and box are its 0).
enum class Filter : uint32_t { Gaussian, Box, Trilinear, Anisotropic };
constexpr const char* kFilterNames[] = {"gaussian", "box", "trilinear", "anisotropic"};

constexpr int kMaxLevels = 15;  // visibility.glsl: levels of a 16384-texel face

const plugin::ParamSpec kParams[] = {
    {"resolution", ParamType::Int, 1024, 16, 16384, "texels",
     "shadow-map texels per side of each face (point, rect and disk lights: six faces in a 3 x 2 atlas); "
     "a power of two for the mip filters"},
    {"variant", ParamType::Enum, double(Variant::Vsm), 0, 0, "",
     "vsm: moments t, t^2 and Chebyshev's bound; evsm: the same for exponentially warped depths; esm: e^{c t}",
     kVariantNames, uint32_t(std::size(kVariantNames))},
    {"moment_format", ParamType::Enum, double(MomentFormat::Auto), 0, 0, "",
     "storage of the filtered map: auto (rg32f; evsm: rgba32f), rg32f (evsm: positive warp only), rgba32f, "
     "rgba16f (half the memory; evsm's exponents clamp to 5.54, esm's to 200, vsm needs min_variance >= 1e-4)",
     kMomentFormatNames, uint32_t(std::size(kMomentFormatNames))},
    {"filter", ParamType::Enum, double(Filter::Gaussian), 0, 0, "",
     "gaussian or box: separable blur of blur_radius; trilinear or anisotropic: mip chain read at the pixel's "
     "footprint",
     kFilterNames, uint32_t(std::size(kFilterNames))},
    {"blur_radius", ParamType::Int, 2, 0, 32, "texels",
     "gaussian, box: taps each side of the blur (gaussian sigma = radius / 2); 0: no blur, bilinear lookups only"},
    {"lod_bias", ParamType::Float, 0, -4, 14, "levels",
     "trilinear, anisotropic: levels added to the footprint's (> 0: softer)"},
    {"max_anisotropy", ParamType::Int, 8, 1, 16, "", "anisotropic: lookups along the footprint's long axis"},
    {"min_variance", ParamType::Float, 1e-6, 0, 0.25, "t^2",
     "vsm, evsm: least variance, in normalised depth squared (depth runs 0..1 over the scene)"},
    {"bleeding_reduction", ParamType::Float, 0.2, 0, 0.99, "",
     "vsm, evsm: Chebyshev bounds below it become 0, the rest is rescaled (Lauritzen 2007)"},
    {"positive_exponent", ParamType::Float, 40, 0, 1e4, "",
     "evsm: c+ of e^{c+ (2t - 1)}; clamped to 42 (32-bit formats) or 5.54 (rgba16f)"},
    {"negative_exponent", ParamType::Float, 5, 0, 1e4, "",
     "evsm with 4 channels: c- of -e^{-c- (2t - 1)}; clamped like positive_exponent"},
    {"esm_exponent", ParamType::Float, 80, 0, 1e4, "",
     "esm: c of e^{c (z - t)}, filtered in log space (no overflow); clamped to 200 for rgba16f (rounding); larger "
     "is darker near contacts but shrinks shadows by the filter's width"},
};

// The largest EVSM exponent for a storage format: EVSM stores e^{2 c t'} with t' up to
// 1, so 2c < ln(FLT_MAX) = 88.72 (fp32) and ln(65504) = 11.09 (fp16): c < 44.36 and
// 5.545. Lauritzen & McCool use 42 (room for Chebyshev's sum of the variance and the
// squared distance, each up to e^{84}) and 5.54. ESM filters its depths in log space
// (moments.glsl FilterSum) and never forms e^{c z}, so nothing overflows; but V =
// e^{c (z_f - t)} turns a rounding error dz of the stored depth into a relative error
// c dz of V. Half floats store depths in [0.5, 1) to dz = 2^-12: c <= 200 keeps that
// below 5 %. Single floats (dz = 2^-25) stay below it for every c the parameter allows.
constexpr float kEvsmMaxExponentFp32 = 42.0f;
constexpr float kEvsmMaxExponentFp16 = 5.54f;
constexpr float kEsmMaxExponentFp16 = 200.0f;

struct Settings {
    uint32_t resolution = 1024;
    Variant variant = Variant::Vsm;
    VkFormat format = VK_FORMAT_R32G32_SFLOAT;
    const char* formatName = "rg32f";  // the GLSL format qualifier
    uint32_t channels = 2;
    Filter filter = Filter::Gaussian;
    int blurRadius = 2;
    float lodBias = 0.0f;
    float maxAnisotropy = 8.0f;
    float minVariance = 1e-6f;
    float bleedingReduction = 0.2f;
    glm::vec2 exponents{0.0f};  // clamped: x c+ (esm: c), y c-

    bool blurs() const { return (filter == Filter::Gaussian || filter == Filter::Box) && blurRadius > 0; }
    bool mips() const { return filter == Filter::Trilinear || filter == Filter::Anisotropic; }
};

// An exponent from the parameters, clamped to what the storage format allows (with a
// warning: the value asked for is not the one used).
float clampExponent(const plugin::ParamValues& params, const char* name, float limit, const char* format)
{
    const float value = params.getFloat(name);
    if (value <= limit) return value;
    spdlog::warn("vsm: {} {} exceeds {}, the largest {} allows (plugins/vsm/README.md); using {}", name, value, limit,
                 format, limit);
    return limit;
}

Settings readSettings(const plugin::ParamValues& params)
{
    Settings s;
    s.resolution = uint32_t(params.getInt("resolution"));
    s.variant = Variant(params.getEnumIndex("variant"));
    MomentFormat format = MomentFormat(params.getEnumIndex("moment_format"));
    if (format == MomentFormat::Auto) format = s.variant == Variant::Evsm ? MomentFormat::Rgba32f : MomentFormat::Rg32f;
    const MomentStorage& storage = kMomentStorage[uint32_t(format)];
    s.format = storage.format;
    s.formatName = storage.glslName;
    s.channels = storage.channels;
    s.filter = Filter(params.getEnumIndex("filter"));
    s.blurRadius = params.getInt("blur_radius");
    s.lodBias = params.getFloat("lod_bias");
    s.maxAnisotropy = float(params.getInt("max_anisotropy"));
    s.minVariance = params.getFloat("min_variance");
    s.bleedingReduction = params.getFloat("bleeding_reduction");

    const float evsmLimit = format == MomentFormat::Rgba16f ? kEvsmMaxExponentFp16 : kEvsmMaxExponentFp32;
    if (s.variant == Variant::Evsm) {
        s.exponents = {clampExponent(params, "positive_exponent", evsmLimit, s.formatName),
                       clampExponent(params, "negative_exponent", evsmLimit, s.formatName)};
    } else if (s.variant == Variant::Esm) {
        s.exponents = {format == MomentFormat::Rgba16f
                           ? clampExponent(params, "esm_exponent", kEsmMaxExponentFp16, s.formatName)
                           : params.getFloat("esm_exponent"),
                       0.0f};
    }
    if (s.mips() && !std::has_single_bit(s.resolution)) {
        throw ConfigError(fmt::format("vsm: resolution: must be a power of two with filter {} (each mip level halves "
                                      "every cube face), got {}; use {} or {}",
                                      kFilterNames[uint32_t(s.filter)], s.resolution, std::bit_floor(s.resolution),
                                      std::bit_ceil(s.resolution)));
    }
    return s;
}

// Mip levels down to faces of one texel.
int levelCount(const Settings& s) { return s.mips() ? std::min(int(std::bit_width(s.resolution)), kMaxLevels) : 1; }

std::vector<gpu::ShaderDefine> momentDefines(const Settings& s)
{
    return {{"VSM_VARIANT", std::to_string(uint32_t(s.variant))},
            {"MOMENT_CHANNELS", std::to_string(s.channels)},
            {"MOMENT_FORMAT", s.formatName}};
}

struct BlurPush {
    glm::ivec2 axis{1, 0};
    int32_t radius = 1;
    int32_t faceTexels = 1;
    float exponent = 0.0f;  // ESM's c
};

class VsmShadow final : public plugin::Technique {
public:
    explicit VsmShadow(const plugin::TechniqueSetup& setup);

    void update(const scene::Light& light, const scene::Aabb& sceneBounds) override;
    void registerPasses(graph::RenderGraph& graph, const plugin::LightPassIo& io) override;

private:
    void checkFormat(const char* use, VkFormatFeatureFlags needed) const;
    // The moment map's level `level` (0: full size) as a graph image.
    std::string levelName(const plugin::LightPassIo& io, int level) const;
    void recordMoments(const graph::PassContext& pass, const std::string& depth, const std::string& moments) const;
    void recordBlur(const graph::PassContext& pass, const std::string& in, const std::string& out,
                    glm::ivec2 axis) const;
    void recordDownsample(const graph::PassContext& pass, const std::string& finer, const std::string& coarser) const;
    void bindVisibility(const graph::PassContext& pass, gpu::DescriptorPush& descriptors,
                        const std::vector<std::string>& levels) const;

    gpu::Context& context_;
    const Settings settings_;
    const int levels_;
    render::ShadowMap shadowMap_;
    gpu::Pipeline moments_;
    gpu::Pipeline blur_;
    gpu::Pipeline downsample_;
    plugin::VisibilityFunction visibility_;
    gpu::Sampler depthSampler_;   // nearest, for texelFetch of the depth map
    gpu::Sampler linearSampler_;  // bilinear lookups of the filtered map
};

VsmShadow::VsmShadow(const plugin::TechniqueSetup& setup)
    : context_(setup.context),
      settings_(readSettings(setup.params)),
      levels_(levelCount(settings_)),
      // A blur reaching past a cube edge reads the texels there in the face's own guard
      // band; mip chains keep power-of-two faces and their cube edges (README).
      shadowMap_(setup, settings_.resolution, "vsm",
                 settings_.blurs() && !settings_.mips()
                     ? render::kernelGuardTexels(float(settings_.blurRadius) + 1.0f, settings_.resolution)
                     : 0u)
{
    // A blurred map is read bilinearly (one texel) after a blur of blur_radius texels; a
    // mip chain may be read at any level, so every texel can matter.
    shadowMap_.setFootprint(settings_.mips() ? render::CasterView::kWholeView
                                             : float(settings_.blurs() ? settings_.blurRadius : 0) + 1.0f);
    checkFormat("a storage image read with bilinear filtering",
                VK_FORMAT_FEATURE_STORAGE_IMAGE_BIT | VK_FORMAT_FEATURE_SAMPLED_IMAGE_FILTER_LINEAR_BIT);
    std::vector<gpu::ShaderDefine> defines = momentDefines(settings_);
    std::ranges::copy(shadowMap_.shaderDefines(), std::back_inserter(defines));
    moments_ = plugin::createComputePipeline(setup, "moments", "moments.comp", defines, sizeof(glm::vec2));
    if (settings_.blurs()) {
        std::vector<gpu::ShaderDefine> blur = defines;
        blur.push_back({"BLUR_KERNEL", settings_.filter == Filter::Gaussian ? "0" : "1"});
        blur_ = plugin::createComputePipeline(setup, "blur", "blur.comp", blur, sizeof(BlurPush));
    }
    if (settings_.mips())
        downsample_ = plugin::createComputePipeline(setup, "downsample", "downsample.comp", defines, sizeof(float));
    defines.push_back({"FILTER", std::to_string(settings_.mips() ? uint32_t(settings_.filter) - 1 : 0u)});
    defines.push_back({"LEVELS", std::to_string(levels_)});
    defines.push_back({"EXPONENTS", fmt::format("vec2({}, {})", plugin::floatLiteral(settings_.exponents.x),
                                                plugin::floatLiteral(settings_.exponents.y))});
    defines.push_back(plugin::floatDefine("MIN_VARIANCE", settings_.minVariance));
    defines.push_back(plugin::floatDefine("BLEEDING_REDUCTION", settings_.bleedingReduction));
    defines.push_back(plugin::floatDefine("LOD_BIAS", settings_.lodBias));
    defines.push_back(plugin::floatDefine("MAX_ANISOTROPY", settings_.maxAnisotropy));
    // 8 x 8 tiles: neighbouring receivers read neighbouring texels of the moment map.
    visibility_ = plugin::VisibilityFunction(setup, "visibility.glsl", defines, 8, 8);

    depthSampler_ = render::createShadowDepthSampler(context_);
    linearSampler_ = gpu::createSampler(context_, VK_FILTER_LINEAR, VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE);
}

void VsmShadow::checkFormat(const char* use, VkFormatFeatureFlags needed) const
{
    VkFormatProperties properties{};
    vkGetPhysicalDeviceFormatProperties(context_.physicalDevice(), settings_.format, &properties);
    if ((properties.optimalTilingFeatures & needed) != needed) {
        throw ConfigError(fmt::format("vsm: moment_format: {} cannot be {} on this device; choose another format",
                                      settings_.formatName, use));
    }
}

void VsmShadow::update(const scene::Light& light, const scene::Aabb& sceneBounds)
{
    shadowMap_.update(light, sceneBounds);
}

std::string VsmShadow::levelName(const plugin::LightPassIo& io, int level) const
{
    return level == 0 ? io.local("moments") : io.local(fmt::format("moments_mip{}", level));
}

void VsmShadow::registerPasses(graph::RenderGraph& graph, const plugin::LightPassIo& io)
{
    // The moments need the casters' depths as they are: no rasterizer bias.
    const std::string depth = io.local("shadow_map");
    shadowMap_.addDepthPass(graph, depth, {});

    const uint32_t width = shadowMap_.atlasWidth(), height = shadowMap_.atlasHeight();
    const std::string moments = levelName(io, 0);
    graph.declareImage({moments, width, height, settings_.format});
    graph.addPass(moments, graph::QueueKind::Compute)
        .read(depth, graph::Usage::Sampled)
        .write(moments, graph::Usage::Storage)
        .dependsOn(io.lightState)
        .execute([this, depth, moments](graph::PassContext& pass) { recordMoments(pass, depth, moments); });

    // What the lookup reads: the blurred map, the mip chain, or the moments themselves.
    std::vector<std::string> levels = {moments};
    if (settings_.blurs()) {
        const std::string scratch = io.local("moments_blur_x"), blurred = io.local("moments_blurred");
        graph.declareImage({scratch, width, height, settings_.format});
        graph.declareImage({blurred, width, height, settings_.format});
        graph.addPass(io.local("blur_x"), graph::QueueKind::Compute)
            .read(moments, graph::Usage::Storage)
            .write(scratch, graph::Usage::Storage)
            .dependsOn(io.lightState)
            .execute([this, moments, scratch](graph::PassContext& pass) { recordBlur(pass, moments, scratch, {1, 0}); });
        graph.addPass(io.local("blur_y"), graph::QueueKind::Compute)
            .read(scratch, graph::Usage::Storage)
            .write(blurred, graph::Usage::Storage)
            .dependsOn(io.lightState)
            .execute([this, scratch, blurred](graph::PassContext& pass) { recordBlur(pass, scratch, blurred, {0, 1}); });
        levels = {blurred};
    }
    for (int level = 1; level < levels_; ++level) {
        const std::string finer = levels.back(), coarser = levelName(io, level);
        graph.declareImage({coarser, std::max(width >> level, 1u), std::max(height >> level, 1u), settings_.format});
        graph.addPass(coarser, graph::QueueKind::Compute)
            .read(finer, graph::Usage::Storage)
            .write(coarser, graph::Usage::Storage)
            .dependsOn(io.lightState)
            .execute([this, finer, coarser](graph::PassContext& pass) { recordDownsample(pass, finer, coarser); });
        levels.push_back(coarser);
    }

    plugin::addVisibilityFunction(graph, io, visibility_, levels,
                                  [this, levels](const graph::PassContext& pass, gpu::DescriptorPush& descriptors) {
                                      bindVisibility(pass, descriptors, levels);
                                  });
}

void VsmShadow::recordMoments(const graph::PassContext& pass, const std::string& depth,
                              const std::string& moments) const
{
    VkCommandBuffer cmd = pass.cmd();
    moments_.bind(cmd);
    gpu::DescriptorPush()
        .sampledImage("shadowDepth", pass.image(depth), depthSampler_, pass.layout(depth))
        .storageImage("momentsOut", pass.image(moments))
        .storageBuffer("shadowMapBuffer", shadowMap_.buffer())
        .push(context_, cmd, moments_);
    moments_.pushConstants(cmd, &settings_.exponents, sizeof(glm::vec2));
    moments_.dispatchOver(cmd, pass.image(moments));
}

void VsmShadow::recordBlur(const graph::PassContext& pass, const std::string& in, const std::string& out,
                           glm::ivec2 axis) const
{
    VkCommandBuffer cmd = pass.cmd();
    blur_.bind(cmd);
    gpu::DescriptorPush()
        .storageImage("momentsIn", pass.image(in))
        .storageImage("momentsOut", pass.image(out))
        .push(context_, cmd, blur_);
    const BlurPush push{axis, settings_.blurRadius, int32_t(shadowMap_.faceTexels()), settings_.exponents.x};
    blur_.pushConstants(cmd, &push, sizeof(push));
    blur_.dispatchOver(cmd, pass.image(out));
}

void VsmShadow::recordDownsample(const graph::PassContext& pass, const std::string& finer,
                                 const std::string& coarser) const
{
    VkCommandBuffer cmd = pass.cmd();
    downsample_.bind(cmd);
    gpu::DescriptorPush()
        .storageImage("finer", pass.image(finer))
        .storageImage("coarser", pass.image(coarser))
        .push(context_, cmd, downsample_);
    downsample_.pushConstants(cmd, &settings_.exponents.x, sizeof(float));
    downsample_.dispatchOver(cmd, pass.image(coarser));
}

void VsmShadow::bindVisibility(const graph::PassContext& pass, gpu::DescriptorPush& descriptors,
                               const std::vector<std::string>& levels) const
{
    std::vector<const gpu::Image*> images;
    for (const std::string& level : levels) images.push_back(&pass.image(level));
    descriptors.storageBuffer("shadowMapBuffer", shadowMap_.buffer())
        .sampledImages("momentLevels", images, linearSampler_, pass.layout(levels.front()));
}

} // namespace
} // namespace penumbra::vsm

PENUMBRA_DEFINE_PLUGIN("vsm", "1.0.0", "variance shadow maps: VSM, EVSM and ESM with separable blur or mip filtering",
                       penumbra::vsm::kParams, penumbra::vsm::VsmShadow)
