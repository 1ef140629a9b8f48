// The example plugin: the smallest complete shadow technique. A hard shadow for every
// light type: the engine's shadow map (render/ShadowMap.h: one map for spot and
// directional lights, six cube faces in one atlas for point, rect and disk lights), then
// one compute pass that makes one nearest-texel comparison per pixel and writes the
// light's visibility image V_l. docs/plugins.md walks through it; plugins/hard is the
// full technique (bias modes, filters).
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/graph/PassContext.h"
#include "penumbra/plugin/Plugin.h"
#include "penumbra/plugin/Technique.h"
#include "penumbra/render/ShadowMap.h"

#include <fmt/format.h>

#include <string>

namespace {

using namespace penumbra;

// Reflected parameters: configs set them as "shadow": {"technique": "example",
// "resolution": 2048}, the command line as --set example.resolution=2048.
const plugin::ParamSpec kParams[] = {
    {"resolution", plugin::ParamType::Int, 1024, 16, 8192, "texels",
     "shadow-map texels per side of each face (point, rect and disk lights: six faces in a 3 x 2 atlas)"},
    {"depth_bias", plugin::ParamType::Float, 4.0, 0.0, 1e5, "r",
     "constant depth bias away from the light, in Vulkan's minimum resolvable depth differences r"},
};

// Slope-scaled bias, fixed here to keep the example short (plugins/hard reflects it).
constexpr float kSlopeBias = 2.0f;

class ExampleShadow final : public plugin::Technique {
public:
    explicit ExampleShadow(const plugin::TechniqueSetup& setup)
        : context_(setup.context),
          depthBias_(setup.params.getFloat("depth_bias")),
          shadowMap_(setup, uint32_t(setup.params.getInt("resolution")), "example")
    {
        // What the visibility pass reads, for the engine's caster culling: one texel per
        // receiver point (half a texel around the point), compared with the point's own
        // depth (docs/plugins.md, "Shadow maps").
        shadowMap_.setFootprint(0.5f);
        shadowMap_.setOwnDepthCompare(0);

        // The shader's path is relative: setup.shaders searches this plugin's folder,
        // then the engine's shaders/ (for the #included common/*.glsl). Its bindings
        // come from the shader itself.
        gpu::ComputePipelineDesc visibility;
        visibility.name = fmt::format("light{}.example.visibility", setup.lightIndex);
        visibility.shader = "visibility.comp";
        visibility_ = gpu::Pipeline(context_, setup.shaders, visibility);

        // Nearest, with the comparison the shader's sampler2DShadow makes (reversed-Z).
        compareSampler_ = gpu::createSampler(context_, VK_FILTER_NEAREST, VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE,
                                             VK_COMPARE_OP_GREATER_OR_EQUAL);
    }

    void update(const scene::Light& light, const scene::Aabb& sceneBounds) override
    {
        shadowMap_.update(light, sceneBounds);  // refits the frusta to the light and the scene
    }

    void registerPasses(graph::RenderGraph& graph, const plugin::LightPassIo& io) override
    {
        // The depth pass: a transient image and a graphics pass, both named `map`. The
        // graph creates the image, aliases its memory with resources whose lifetimes do
        // not overlap, and inserts every barrier and layout change.
        const std::string map = io.local("shadow_map");
        shadowMap_.addDepthPass(graph, map, {depthBias_, kSlopeBias, 0.0f});

        graph.addPass(io.local("visibility"), graph::QueueKind::Compute)
            .read(io.gPosition, graph::Usage::Storage)
            .read(io.gNormal, graph::Usage::Storage)  // the horizon: V = 0 facing away from the light
            .read(map, graph::Usage::Sampled)
            .write(io.visibility, graph::Usage::Storage)
            .execute([this, io, map](graph::PassContext& pass) { recordVisibility(pass, io, map); });
    }

private:
    void recordVisibility(const graph::PassContext& pass, const plugin::LightPassIo& io, const std::string& map) const
    {
        VkCommandBuffer cmd = pass.cmd();
        visibility_.bind(cmd);
        // By the names visibility.comp gives them; a name it does not declare throws.
        gpu::DescriptorPush()
            .storageImage("gPosition", pass.image(io.gPosition))
            .storageImage("gNormal", pass.image(io.gNormal))
            .sampledImage("shadowMap", pass.image(map), compareSampler_, pass.layout(map))
            .storageImage("visibilityOut", pass.image(io.visibility))
            .storageBuffer("shadowMapBuffer", shadowMap_.buffer())
            .push(context_, cmd, visibility_);
        visibility_.dispatchOver(cmd, pass.image(io.visibility));  // one invocation per pixel
    }

    gpu::Context& context_;
    const float depthBias_;
    render::ShadowMap shadowMap_;
    gpu::Pipeline visibility_;
    gpu::Sampler compareSampler_;
};

} // namespace

PENUMBRA_DEFINE_PLUGIN("example", "1.1.0", "hard shadow map for every light type: the minimal plugin", kParams,
                       ExampleShadow)
