// The example plugin: the smallest complete shadow technique. A hard shadow for every
// light type: the engine's shadow map (render/ShadowMap.h: one map for spot and
// directional lights, six cube faces in one atlas for point, rect and disk lights), then
// one compute pass that makes one nearest-texel comparison per pixel and writes the
// light's visibility image V_l. docs/plugins.md walks through it; plugins/hard is the
// full technique (bias modes, filters).
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/graph/PassContext.h"
#include "penumbra/plugin/ComputePipeline.h"
#include "penumbra/plugin/Plugin.h"
#include "penumbra/plugin/ShadowMapParams.h"
#include "penumbra/plugin/Technique.h"
#include "penumbra/plugin/VisibilityPass.h"
#include "penumbra/render/ShadowMap.h"


#include <string>

namespace {

using namespace penumbra;

// Reflected parameters: configs set them as "shadow": {"technique": "example",
// "resolution": 2048}, the command line as --set example.resolution=2048.
// Both are parameters every shadow-map technique has, worded once in plugin/ShadowMapParams.h.
const plugin::ParamSpec kParams[] = {plugin::shadowResolutionParam(1024, 8192), plugin::kShadowDepthBiasParam};

// Slope-scaled bias, fixed here to keep the example short (plugins/hard reflects it).
constexpr float kSlopeBias = 2.0f;

class ExampleShadow final : public plugin::Technique {
public:
    explicit ExampleShadow(const plugin::TechniqueSetup& setup)
        : depthBias_(setup.params.getFloat("depth_bias")),
          shadowMap_(setup, uint32_t(setup.params.getInt("resolution")), "example")
    {
        // What the visibility pass reads, for the engine's caster culling: one texel per
        // receiver point (half a texel around the point), compared with the point's own
        // depth (docs/plugins.md, "Declaring what the lookups read").
        shadowMap_.setFootprint(0.5f);
        shadowMap_.setOwnDepthCompare(0);

        // The shader's path is relative: setup.shaders searches this plugin's folder,
        // then the engine's shaders/ (for the #included common/*.glsl). Its bindings
        // come from the shader itself.
        // Named setup.local("visibility"): "light0.example.visibility".
        visibility_ = plugin::createComputePipeline(setup, "visibility", "visibility.comp",
                                                    shadowMap_.shaderDefines());  // the map's layout, compiled in

        // Nearest, with the comparison the shader's sampler2DShadow makes (reversed-Z).
        compareSampler_ = render::createShadowCompareSampler(setup.context);
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

        // The pass that writes V_l (plugin/VisibilityPass.h): one invocation per pixel,
        // reading the G-buffer's position and normal (the normal for the horizon: V = 0
        // facing away from the light). It binds those and V_l; the technique adds the map
        // and its buffer, by the names visibility.comp gives them (a name the shader does
        // not declare throws).
        const auto bind = [this, map](const graph::PassContext& pass, gpu::DescriptorPush& descriptors) {
            descriptors.sampledImage("shadowMap", pass.image(map), compareSampler_, pass.layout(map))
                .storageBuffer("shadowMapBuffer", shadowMap_.buffer());
        };
        plugin::addVisibilityPass(graph, io, visibility_, bind)
            .read(map, graph::Usage::Sampled)
            .dependsOn(io.lightState)
            .dependsOn(io.cameraState);
    }

private:
    const float depthBias_;
    render::ShadowMap shadowMap_;
    gpu::Pipeline visibility_;
    gpu::Sampler compareSampler_;
};

} // namespace

PENUMBRA_DEFINE_PLUGIN("example", "1.1.0", "hard shadow map for every light type: the minimal plugin", kParams,
                       ExampleShadow)
