#pragma once
// A shadow technique instance: one per light that uses it. It registers its passes into
// the frame's render graph and writes that light's visibility image V_l (DESIGN.md: the
// one contract between the engine and a technique), drawing casters only through the
// engine's caster interface (render/Casters.h).
#include "penumbra/gpu/ShaderCompiler.h"
#include "penumbra/plugin/GBuffer.h"
#include "penumbra/graph/RenderGraph.h"
#include "penumbra/plugin/Params.h"
#include "penumbra/render/Casters.h"
#include "penumbra/render/ShadowMap.h"
#include "penumbra/scene/Scene.h"

#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra::gpu {
class Buffer;
class Context;
class Image;
} // namespace penumbra::gpu

namespace penumbra::plugin {

struct VisibilityInShading;

// Everything a technique needs when it is created; references stay valid for the
// technique's lifetime.
struct TechniqueSetup {
    gpu::Context& context;
    // Searches the plugin's shader folder first, then the engine's shaders/ (for
    // common/*.glsl).
    const gpu::ShaderCompiler& shaders;
    const render::Casters& casters;
    // The CPU scene (meshes, materials, textures, instances and their world transforms),
    // for techniques that work on geometry outside the GPU (a CPU ray tracer). Animated
    // frames move its nodes in place; instancesMoved() says which instances moved.
    const scene::Scene& scene;
    const ParamValues& params;
    const scene::Light& light;      // as configured (the first frame's state)
    scene::Aabb sceneBounds;
    uint32_t lightIndex = 0;
    uint32_t width = 0;             // the visibility image's size (the output's)
    uint32_t height = 0;
    // Prefix for the technique's own names (pipelines, buffers, passes, resources), so
    // that two lights using one technique never collide: "light0.hard.". The same as
    // LightPassIo::prefix.
    std::string prefix;

    std::string local(std::string_view name) const { return prefix + std::string(name); }

    // What render::ShadowMap takes: `render::ShadowMap map(setup, resolution, "mine")`.
    operator render::ShadowMapSetup() const { return {context, shaders, casters, light, sceneBounds, lightIndex}; }
};

// Names of the engine's images a technique may use, as declared in the graph, and the
// one it must write.
struct LightPassIo {
    // Prefix for the technique's own pass and resource names, so that two lights using
    // one technique never collide: "light0.hard.".
    std::string prefix;
    // The G-buffer (screen size): read it with readGBuffer / bindGBuffer and, in GLSL,
    // common/gbuffer.glsl's gbufferPosition / gbufferNormal (plugin/GBuffer.h).
    GBufferIo gbuffer;
    // V_l: screen size, values in [0, 1], written as VISIBILITY_FORMAT by a shader
    // (shaders/common/visibility.glsl) or as a float by a clear. The
    // technique must write every pixel of it in one of its passes (Usage::Storage or
    // Usage::ColorAttachment / TransferDst).
    std::string visibility;
    // What the technique's passes may depend on, so that the engine keeps their results
    // while it holds instead of running them again (graph::PassBuilder::dependsOn;
    // docs/plugins.md, "Keeping what did not change"): `lightState` for a pass whose
    // results follow from what it reads, the light, the casters the light sees and the
    // technique's parameters alone (render::lightState: a shadow map's moments, its
    // summed-area table; render::ShadowMap's depth passes declare it themselves), and
    // `cameraState` as well for a pass over the G-buffer (the visibility pass). A pass
    // that also reads state of the technique's own that changes between frames (a
    // progressive sample count, a table the CPU rewrites) declares neither: it runs every
    // frame, and so do the passes that read what it writes.
    std::string lightState;
    std::string cameraState;

    std::string local(std::string_view name) const { return prefix + std::string(name); }

    // Resources the technique keeps from frame to frame (a persistent atlas, a table its
    // passes update): declared with imported = true (an image with the initialLayout the
    // technique keeps it in between frames) and bound here to the technique's own object,
    // which must live as long as the technique. Passes then read and write them with the
    // graph's barriers, like any other resource.
    std::function<void(std::string_view name, const gpu::Image& image)> bindImage;
    std::function<void(std::string_view name, const gpu::Buffer& buffer)> bindBuffer;
    // Set by the engine where nothing but shading reads V_l: takes a visibility function
    // into shading (true), and io.visibility is then not written at all. Called by
    // addVisibilityFunction (plugin/VisibilityFunction.h), not by techniques.
    std::function<bool(const VisibilityInShading& function)> evaluateInShading;
    // The pixels the light can light this frame (frame/LightInfluence.h lightScreenRect):
    // shading reads V_l nowhere else. Asked as a pass records, so it follows the camera and
    // the light without the graph being declared again; unset means the whole screen.
    // addVisibilityStepPass runs the technique's per-pixel passes only over it.
    std::function<VkRect2D()> screenRegion;
    // Writes V = 1 over `image` (a VISIBILITY_FORMAT storage image) outside `inside`, in a
    // compute pass's command buffer: the rest of V_l where the visibility pass ran over
    // screenRegion only.
    std::function<void(VkCommandBuffer cmd, const gpu::Image& image, VkRect2D inside)> fillOutside;
};

// One figure of a technique's last frame (memory it used, work it did, what it had to
// drop): `render --stats`, `bench` and `graph` print them beside the engine's own.
struct TechniqueFigure {
    std::string name;  // "fragments", "pool_used_mib"
    double value = 0.0;
    std::string unit;  // "", "MiB", "texels"
    bool operator==(const TechniqueFigure&) const = default;
};

class Technique {
public:
    virtual ~Technique() = default;

    // The light or the scene moved (an animated frame): refit frusta, update buffers.
    // Called before the frame's graph executes; the graph itself is not rebuilt.
    virtual void update(const scene::Light& light, const scene::Aabb& sceneBounds) = 0;

    // Scene nodes moved (an animated frame): `instances` (ascending, indices into
    // TechniqueSetup::scene.instances) have new world transforms, which the scene already
    // holds. Called before update(), only when something moved. Techniques that draw
    // through render::Casters need nothing here (the engine updates the instance table
    // they draw with); one that keeps its own copy of the geometry (an Embree scene)
    // refits or rebuilds it.
    virtual void instancesMoved(std::span<const uint32_t> instances) { (void)instances; }

    // Declares the technique's resources and passes (with their execute callbacks) into
    // the frame's graph. Called once per graph build; the callbacks run every frame and
    // read the state that update() left.
    virtual void registerPasses(graph::RenderGraph& graph, const LightPassIo& io) = 0;

    // The figures of the frame that ran last, read after it finished. Default: none.
    virtual std::vector<TechniqueFigure> figures() const { return {}; }

    // Called after every frame, once it finished: true asks for the frame to be drawn
    // again, because the technique found a resource too small for the frame (its results
    // are incomplete) and grew it, or found what it stores for this view still short of
    // what it can store (an adaptive shadow map's quadtree, which a still view refines
    // level by level). The renderer then declares the frame's graph again
    // (registerPasses is called anew, with the new sizes) and draws the frame again, at
    // most frame::kMaxRedraws times in one renderFrame(). A technique past its own limit
    // reports that in its figures and returns false. Default: false.
    virtual bool wantsRedraw() { return false; }
};

} // namespace penumbra::plugin
