// The example plugin: the smallest complete shadow technique. A hard shadow map for spot
// and directional lights: one depth pass from the light, then one compute pass that makes
// one nearest-texel comparison per pixel and writes the light's visibility image V_l.
// docs/plugins.md walks through it; plugins/hard is the full technique (cube maps for
// point and area lights, slope bias and clamp, alpha-masked casters, filtering).
#include "penumbra/core/Error.h"
#include "penumbra/gpu/Context.h"
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/graph/GraphExecutor.h"
#include "penumbra/plugin/Plugin.h"
#include "penumbra/plugin/Technique.h"
#include "penumbra/render/Projection.h"

#include <fmt/format.h>
#include <glm/glm.hpp>

#include <iterator>
#include <string>

namespace {

using namespace penumbra;

// Reflected parameters: configs set them as "shadow": {"technique": "example",
// "resolution": 2048}, the command line as --set example.resolution=2048.
const plugin::ParamSpec kParams[] = {
    {"resolution", plugin::ParamType::Int, 1024, 16, 8192, "texels", "shadow-map texels per side"},
    {"depth_bias", plugin::ParamType::Float, 4.0, 0.0, 1e5, "depth units",
     "constant depth bias away from the light, in units of the depth format's resolution"},
};

constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;
// Slope-scaled bias, fixed here to keep the example short (plugins/hard reflects it).
constexpr float kSlopeBias = 2.0f;

// visibility.comp's push constants.
struct VisibilityPush {
    glm::mat4 lightViewProj;
    glm::vec4 towardsLight;  // xyz the light's position (w = 1) or the direction towards it (w = 0)
};

class ExampleShadow final : public plugin::Technique {
public:
    explicit ExampleShadow(const plugin::TechniqueSetup& setup)
        : context_(setup.context),
          casters_(setup.casters),
          lightIndex_(setup.lightIndex),
          resolution_(uint32_t(setup.params.getInt("resolution"))),
          depthBias_(setup.params.getFloat("depth_bias"))
    {
        // Shader paths are relative: setup.shaders searches this plugin's folder, then the
        // engine's shaders/ (for the #included common/*.glsl).
        gpu::GraphicsPipelineDesc depth;
        depth.name = "example.shadow_map";
        depth.vertexShader = "shadow_depth.vert";
        depth.bindings = {{0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER}};  // the caster instance table
        depth.pushConstantBytes = sizeof(glm::mat4);
        depth.vertexLayout = casters_.positionLayout();
        depth.depthFormat = kDepthFormat;
        depth.depthBias = true;
        depth.cullMode = VK_CULL_MODE_NONE;  // both faces cast: open meshes must not leak light
        depthPipeline_ = gpu::Pipeline(context_, setup.shaders, depth);

        gpu::ComputePipelineDesc visibility;
        visibility.name = "example.visibility";
        visibility.shader = "visibility.comp";
        visibility.bindings = {{0, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE},
                               {1, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER},
                               {2, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE},
                               {3, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE}};
        visibility.pushConstantBytes = sizeof(VisibilityPush);
        visibilityPipeline_ = gpu::Pipeline(context_, setup.shaders, visibility);

        compareSampler_ = gpu::createSampler(context_, VK_FILTER_NEAREST, VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE,
                                             VK_COMPARE_OP_GREATER_OR_EQUAL);
        update(setup.light, setup.sceneBounds);
    }

    void update(const scene::Light& light, const scene::Aabb& sceneBounds) override
    {
        // Spot: a perspective frustum over the outer cone; directional: an orthographic
        // box around the scene. Both are one frustum.
        lightViewProj_ = render::shadowFrusta(light, sceneBounds).front().viewProj;
        // The light as the horizon test sees it: a point, or a direction towards it.
        towardsLight_ = light.type == scene::LightType::Directional ? glm::vec4(-light.direction, 0.0f)
                                                                    : glm::vec4(light.position, 1.0f);
    }

    void registerPasses(graph::RenderGraph& graph, const plugin::LightPassIo& io) override
    {
        // A transient image: the graph creates it, aliases its memory with resources
        // whose lifetimes do not overlap, and inserts every barrier and layout change.
        const std::string map = io.local("depth_map");
        graph.declareImage({.name = map, .width = resolution_, .height = resolution_, .format = kDepthFormat});

        graph.addPass(io.local("shadow_map"), graph::QueueKind::Graphics)
            .write(map, graph::Usage::DepthAttachment)
            .execute([this, map](graph::PassContext& pass) { recordShadowMap(pass, map); });

        graph.addPass(io.local("visibility"), graph::QueueKind::Compute)
            .read(io.gPosition, graph::Usage::Storage)
            .read(io.gNormal, graph::Usage::Storage)
            .read(map, graph::Usage::Sampled)
            .write(io.visibility, graph::Usage::Storage)
            .execute([this, map, io](graph::PassContext& pass) { recordVisibility(pass, io, map); });
    }

private:
    void recordShadowMap(graph::PassContext& pass, const std::string& map) const
    {
        VkRenderingAttachmentInfo depth{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
        depth.imageView = pass.image(map).view();
        depth.imageLayout = pass.layout(map);
        depth.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
        depth.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
        depth.clearValue.depthStencil = {0.0f, 0};  // reversed-Z: far is 0
        VkRenderingInfo info{VK_STRUCTURE_TYPE_RENDERING_INFO};
        info.renderArea = {{0, 0}, {resolution_, resolution_}};
        info.layerCount = 1;
        info.pDepthAttachment = &depth;

        VkCommandBuffer cmd = pass.cmd();
        vkCmdBeginRendering(cmd, &info);
        const VkViewport viewport{0.0f, 0.0f, float(resolution_), float(resolution_), 0.0f, 1.0f};
        vkCmdSetViewport(cmd, 0, 1, &viewport);
        vkCmdSetScissor(cmd, 0, 1, &info.renderArea);
        // Reversed-Z: "away from the light" is towards smaller depth, so the bias is negative.
        vkCmdSetDepthBias(cmd, -depthBias_, 0.0f, -kSlopeBias);
        depthPipeline_.bind(cmd);
        gpu::DescriptorPush().storageBuffer(0, casters_.instanceBuffer()).push(context_, cmd, depthPipeline_);
        depthPipeline_.pushConstants(cmd, &lightViewProj_, sizeof(glm::mat4));
        // Alpha-masked casters are drawn solid here; plugins/hard cuts their holes.
        // The view's resolution lets the engine cull at exactly this map's texels; the
        // footprint says the visibility pass reads one texel per receiver point.
        casters_.draw(cmd, {lightViewProj_, lightIndex_, 0, resolution_, 1.0f}, render::DrawFilter::All);
        vkCmdEndRendering(cmd);
    }

    void recordVisibility(graph::PassContext& pass, const plugin::LightPassIo& io, const std::string& map) const
    {
        VkCommandBuffer cmd = pass.cmd();
        const gpu::Image& out = pass.image(io.visibility);
        visibilityPipeline_.bind(cmd);
        gpu::DescriptorPush()
            .storageImage(0, pass.image(io.gPosition))
            .sampledImage(1, pass.image(map), compareSampler_, pass.layout(map))
            .storageImage(2, out)
            .storageImage(3, pass.image(io.gNormal))
            .push(context_, cmd, visibilityPipeline_);
        const VisibilityPush push{lightViewProj_, towardsLight_};
        visibilityPipeline_.pushConstants(cmd, &push, sizeof(push));
        vkCmdDispatch(cmd, (out.desc().width + 7) / 8, (out.desc().height + 7) / 8, 1);
    }

    gpu::Context& context_;
    const render::Casters& casters_;
    uint32_t lightIndex_;
    uint32_t resolution_;
    float depthBias_;
    gpu::Pipeline depthPipeline_;
    gpu::Pipeline visibilityPipeline_;
    gpu::Sampler compareSampler_;
    glm::mat4 lightViewProj_{1.0f};
    glm::vec4 towardsLight_{0.0f};
};

plugin::Technique* createExampleShadow(const plugin::TechniqueSetup& setup)
{
    const scene::LightType type = setup.light.type;
    if (type != scene::LightType::Spot && type != scene::LightType::Directional) {
        throw Error(fmt::format("example: light {} is a {} light; this plugin shadows spot and directional "
                                "lights only (\"technique\": \"hard\" shadows every type)",
                                setup.lightIndex, scene::lightTypeName(type)));
    }
    return new ExampleShadow(setup);
}

} // namespace

PENUMBRA_PLUGIN_EXPORT const PenumbraPluginInfo* penumbra_plugin_entry()
{
    static const PenumbraPluginInfo info{PENUMBRA_PLUGIN_ABI_VERSION,
                                         "example",
                                         "1.0.0",
                                         "hard shadow map for spot and directional lights: the minimal plugin",
                                         kParams,
                                         uint32_t(std::size(kParams)),
                                         &createExampleShadow,
                                         PENUMBRA_PLUGIN_SHADER_DIR};
    return &info;
}
