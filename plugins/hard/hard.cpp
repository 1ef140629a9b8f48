// The hard shadow-map technique (README.md next to this file): a depth-only pass from
// the light into one frustum (spot: perspective, directional: orthographic box around
// the scene) or six 90° cube faces in a 3 x 2 atlas (point, rect and disk lights, seen
// from their centre), then a compute pass that compares every G-buffer position with
// the map and writes the light's visibility image V_l. Bias modes and filters are
// parameters; the filter and receiver-side bias pick a shader variant
// (visibility_pass.h), the constant and slope-scaled bias are the rasterizer's.
#include "visibility_pass.h"

#include "penumbra/core/Error.h"
#include "penumbra/gpu/Context.h"
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/gpu/Resources.h"
#include "penumbra/graph/GraphExecutor.h"
#include "penumbra/graph/RenderGraph.h"
#include "penumbra/plugin/Plugin.h"
#include "penumbra/plugin/Technique.h"
#include "penumbra/render/Casters.h"
#include "penumbra/render/Projection.h"

#include <fmt/format.h>

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
    {"resolution", ParamType::Int, 2048, 16, 16384, "texels",
     "shadow-map texels per side of each face (point, rect and disk lights: six faces in a 3 x 2 atlas)"},
    {"depth_bias", ParamType::Float, 4, 0, 1e6, "r",
     "constant depth bias in Vulkan's minimum resolvable depth differences r; applied in every bias_mode"},
    {"slope_bias", ParamType::Float, 2, 0, 1000, "",
     "slope-scaled depth bias factor (rasterizer), per texel of the filter's width; bias_mode slope only"},
    {"bias_clamp", ParamType::Float, 0, 0, 1, "depth", "largest rasterizer bias, in NDC depth; 0: no clamp"},
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
    {"pcf_kernel", ParamType::Int, 3, kPcfKernelMin, kPcfKernelMax, "texels",
     "filter pcf: taps per side of the box, odd (centred on the receiver)"},
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
    const int kernel = params.getInt("pcf_kernel");
    if (kernel % 2 == 0) {
        throw ConfigError(fmt::format("hard: pcf_kernel: must be odd (the box is centred on the receiver's texel), "
                                      "got {}; use {} or {}",
                                      kernel, kernel - 1, kernel + 1));
    }
    s.resolution = uint32_t(params.getInt("resolution"));
    s.depthBias = params.getFloat("depth_bias");
    s.slopeBias = params.getFloat("slope_bias");
    s.biasClamp = params.getFloat("bias_clamp");
    s.normalOffsetTexels = params.getFloat("normal_offset");
    s.filterRadiusTexels = params.getFloat("filter_radius");
    s.variant.bias = BiasMode(params.getEnumIndex("bias_mode"));
    s.variant.filter = Filter(params.getEnumIndex("filter"));
    s.variant.pcfKernel = uint32_t(kernel);
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

uint32_t faceCountFor(scene::LightType type)
{
    return type == scene::LightType::Spot || type == scene::LightType::Directional ? 1u : kMaxFaces;
}

// World size of one texel per unit of clip w (visibility_pass.h FaceData::texel). A
// texel spans 2 / R of NDC and NDC x = P00 · x_view / w (orthographic: w = 1), so at
// clip w it spans 2 w / (P00 · R) of the world; the larger of the x and y sizes (an
// orthographic box need not be square).
float worldTexelPerW(const glm::mat4& proj, uint32_t resolution)
{
    const float scale = std::min(std::abs(proj[0][0]), std::abs(proj[1][1]));
    return scale > 0.0f ? 2.0f / (scale * float(resolution)) : 0.0f;
}

class HardShadow final : public plugin::Technique {
public:
    explicit HardShadow(const plugin::TechniqueSetup& setup);
    HardShadow(const HardShadow&) = delete;
    HardShadow& operator=(const HardShadow&) = delete;

    void update(const scene::Light& light, const scene::Aabb& sceneBounds) override;
    void registerPasses(graph::RenderGraph& graph, const plugin::LightPassIo& io) override;

private:
    void recordShadowMap(const graph::PassContext& pass, const std::string& map) const;
    void recordVisibility(const graph::PassContext& pass, const plugin::LightPassIo& io, const std::string& map) const;

    gpu::Context& context_;
    const render::Casters& casters_;
    const uint32_t lightIndex_;
    const Settings settings_;
    const uint32_t faceCount_;
    gpu::Pipeline depth_;        // solid casters: no fragment shader
    gpu::Pipeline depthMasked_;  // alpha-masked casters: a fragment shader cuts the holes
    gpu::Pipeline visibility_;
    gpu::Buffer faces_;  // FaceData[faceCount_], host-visible, written by update()
    std::vector<render::LightFrustum> frusta_;
    glm::vec4 light_{0.0f};  // VisibilityPush::light
    gpu::Sampler compareSampler_;
};

HardShadow::HardShadow(const plugin::TechniqueSetup& setup)
    : context_(setup.context),
      casters_(setup.casters),
      lightIndex_(setup.lightIndex),
      settings_(readSettings(setup.params)),
      faceCount_(faceCountFor(setup.light.type)),
      faces_(setup.context, sizeof(FaceData) * kMaxFaces, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true,
             fmt::format("light{}.hard.faces", setup.lightIndex))
{
    const uint32_t atlasWidth = settings_.resolution * (faceCount_ == kMaxFaces ? 3u : 1u);
    const uint32_t maxDimension = context_.properties().limits.maxImageDimension2D;
    if (atlasWidth > maxDimension) {
        throw ConfigError(fmt::format("hard: resolution: {} texels per face {}needs a {}-texel wide map, more than this "
                                      "device's largest image ({}); use at most {}",
                                      settings_.resolution, faceCount_ == kMaxFaces ? "in a 3 x 2 cube atlas " : "",
                                      atlasWidth, maxDimension, maxDimension / (atlasWidth / settings_.resolution)));
    }

    gpu::GraphicsPipelineDesc d;
    d.name = fmt::format("light{}.hard.shadow_map", lightIndex_);
    d.vertexShader = "shadow_depth.vert";
    d.bindings = {{0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER}};
    d.pushConstantBytes = sizeof(glm::mat4);
    d.vertexLayout = casters_.positionLayout();
    d.depthFormat = VK_FORMAT_D32_SFLOAT;
    d.depthCompare = VK_COMPARE_OP_GREATER_OR_EQUAL;  // reversed-Z: nearer is larger
    d.depthBias = true;
    // Both faces cast: a receiver's own back faces would otherwise let light leak
    // through single-sided or open geometry.
    d.cullMode = VK_CULL_MODE_NONE;
    depth_ = gpu::Pipeline(context_, setup.shaders, d);
    if (casters_.hasAlphaMasked()) {
        d.name += ".masked";
        d.fragmentShader = "shadow_masked.frag";
        d.defines = {{"ALPHA_MASK", "1"}};
        d.bindings = {{0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},
                      {1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},
                      {2, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER}};
        d.vertexLayout = casters_.positionUvLayout();
        depthMasked_ = gpu::Pipeline(context_, setup.shaders, d);
    }

    gpu::ComputePipelineDesc c;
    c.name = fmt::format("light{}.hard.visibility", lightIndex_);
    c.shader = "visibility.comp";
    c.defines = visibilityDefines(settings_.variant);
    c.bindings = visibilityBindings(settings_.variant);
    c.pushConstantBytes = sizeof(VisibilityPush);
    visibility_ = gpu::Pipeline(context_, setup.shaders, c);

    update(setup.light, setup.sceneBounds);
    // Nearest (one texel per compare) unless the hardware bilinear compare is wanted;
    // points outside the map never reach the sampler (the shader calls them lit).
    compareSampler_ = gpu::createSampler(context_, settings_.variant.samplerFilter(),
                                         VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE, VK_COMPARE_OP_GREATER_OR_EQUAL);
}

void HardShadow::update(const scene::Light& light, const scene::Aabb& sceneBounds)
{
    if (faceCountFor(light.type) != faceCount_) {
        throw Error(fmt::format("hard: light {} changed type to {}; the technique was created for a {}-face map",
                                lightIndex_, scene::lightTypeName(light.type), faceCount_));
    }
    frusta_ = render::shadowFrusta(light, sceneBounds);
    auto* faces = static_cast<FaceData*>(faces_.mapped());
    for (size_t i = 0; i < frusta_.size(); ++i) {
        faces[i] = {frusta_[i].viewProj, glm::vec4(worldTexelPerW(frusta_[i].proj, settings_.resolution), 0, 0, 0)};
    }
    if (light.type == scene::LightType::Directional) {
        const float length = glm::length(light.direction);
        light_ = glm::vec4(length > 0.0f ? -light.direction / length : glm::vec3(0.0f, 1.0f, 0.0f), 0.0f);
    } else {
        light_ = glm::vec4(light.position, 1.0f);
    }
}

void HardShadow::registerPasses(graph::RenderGraph& graph, const plugin::LightPassIo& io)
{
    // The map is transient: written and read within the frame, so the graph may alias
    // its memory with other lights' maps.
    const std::string map = io.local("shadow_map");
    const bool cube = faceCount_ == kMaxFaces;
    graph.declareImage({map, settings_.resolution * (cube ? 3u : 1u), settings_.resolution * (cube ? 2u : 1u),
                        VK_FORMAT_D32_SFLOAT});
    graph.addPass(map, graph::QueueKind::Graphics)
        .write(map, graph::Usage::DepthAttachment)
        .execute([this, map](graph::PassContext& pass) { recordShadowMap(pass, map); });

    graph::PassBuilder visibility = graph.addPass(io.local("visibility"), graph::QueueKind::Compute);
    visibility.read(io.gPosition, graph::Usage::Storage)
        .read(map, graph::Usage::Sampled)
        .write(io.visibility, graph::Usage::Storage);
    if (settings_.variant.readsNormals()) visibility.read(io.gNormal, graph::Usage::Storage);
    visibility.execute([this, io, map](graph::PassContext& pass) { recordVisibility(pass, io, map); });
}

void HardShadow::recordShadowMap(const graph::PassContext& pass, const std::string& map) const
{
    VkCommandBuffer cmd = pass.cmd();
    const gpu::Image& image = pass.image(map);
    VkRenderingAttachmentInfo depth{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
    depth.imageView = image.view();
    depth.imageLayout = pass.layout(map);
    depth.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
    depth.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    depth.clearValue.depthStencil = {0.0f, 0};  // reversed-Z: far is 0
    VkRenderingInfo info{VK_STRUCTURE_TYPE_RENDERING_INFO};
    info.renderArea = {{0, 0}, {image.desc().width, image.desc().height}};
    info.layerCount = 1;
    info.pDepthAttachment = &depth;
    vkCmdBeginRendering(cmd, &info);

    // Reversed-Z: "away from the light" is towards smaller depth, so every bias term is
    // negated; a negative clamp bounds the bias from below (Vulkan: max(bias, clamp)).
    // Only bias_mode slope scales with the caster's slope; normal_offset and
    // receiver_plane bias the receiver instead (visibility.comp).
    const float slope =
        settings_.variant.bias == BiasMode::Slope ? settings_.slopeBias * footprintWidthTexels(settings_) : 0.0f;
    vkCmdSetDepthBias(cmd, -settings_.depthBias, -settings_.biasClamp, -slope);

    const uint32_t size = settings_.resolution;
    const bool masked = casters_.hasAlphaMasked();
    for (uint32_t face = 0; face < frusta_.size(); ++face) {
        // Each face draws into its own cell of the atlas (the scissor keeps it there).
        const int32_t x = int32_t((face % 3) * size), y = int32_t((face / 3) * size);
        const VkViewport viewport{float(x), float(y), float(size), float(size), 0.0f, 1.0f};
        const VkRect2D scissor{{x, y}, {size, size}};
        vkCmdSetViewport(cmd, 0, 1, &viewport);
        vkCmdSetScissor(cmd, 0, 1, &scissor);
        const render::CasterView view{frusta_[face].viewProj, lightIndex_, face};
        // The solid pipeline stays bound across faces unless the masked one replaced it.
        if (face == 0 || masked) {
            depth_.bind(cmd);
            gpu::DescriptorPush().storageBuffer(0, casters_.instanceBuffer()).push(context_, cmd, depth_);
        }
        depth_.pushConstants(cmd, &view.viewProj, sizeof(glm::mat4));
        casters_.draw(cmd, view, render::DrawFilter::Solid);
        if (!masked) continue;
        depthMasked_.bind(cmd);
        depthMasked_.pushConstants(cmd, &view.viewProj, sizeof(glm::mat4));
        casters_.draw(cmd, view, render::DrawFilter::AlphaMasked, [&](const gpu::Image& texture) {
            gpu::DescriptorPush()
                .storageBuffer(0, casters_.instanceBuffer())
                .storageBuffer(1, casters_.materialBuffer())
                .sampledImage(2, texture, casters_.textureSampler())
                .push(context_, cmd, depthMasked_);
        });
    }
    vkCmdEndRendering(cmd);
}

void HardShadow::recordVisibility(const graph::PassContext& pass, const plugin::LightPassIo& io,
                                  const std::string& map) const
{
    VkCommandBuffer cmd = pass.cmd();
    const gpu::Image& out = pass.image(io.visibility);
    visibility_.bind(cmd);
    gpu::DescriptorPush descriptors;
    descriptors.storageImage(kBindingPosition, pass.image(io.gPosition))
        .sampledImage(kBindingShadowMap, pass.image(map), compareSampler_, pass.layout(map))
        .storageImage(kBindingVisibility, out)
        .storageBuffer(kBindingFaces, faces_);
    if (settings_.variant.readsNormals()) descriptors.storageImage(kBindingNormal, pass.image(io.gNormal));
    descriptors.push(context_, cmd, visibility_);
    const VisibilityPush push{light_, faceCount_, float(settings_.resolution),
                              settings_.normalOffsetTexels * footprintWidthTexels(settings_),
                              settings_.filterRadiusTexels};
    visibility_.pushConstants(cmd, &push, sizeof(push));
    vkCmdDispatch(cmd, (out.desc().width + 7) / 8, (out.desc().height + 7) / 8, 1);
}

plugin::Technique* createHardShadow(const plugin::TechniqueSetup& setup) { return new HardShadow(setup); }

} // namespace
} // namespace penumbra::hard

PENUMBRA_PLUGIN_EXPORT const PenumbraPluginInfo* penumbra_plugin_entry()
{
    static const PenumbraPluginInfo info{PENUMBRA_PLUGIN_ABI_VERSION,
                                         "hard",
                                         "1.0.0",
                                         "shadow map with constant, slope, normal-offset or receiver-plane bias and "
                                         "none, PCF, Poisson or bilinear filtering",
                                         penumbra::hard::kParams,
                                         uint32_t(std::size(penumbra::hard::kParams)),
                                         &penumbra::hard::createHardShadow,
                                         PENUMBRA_PLUGIN_SHADER_DIR};
    return &info;
}
