#pragma once
// The rasterizer's floor for a config: its scene drawn once forward, as a classic engine
// draws it, for measuring what the frame (FrameRenderer) costs against it. Same
// geometry, same size, same camera and lights as the frame; every pass timed on the GPU
// by the same timestamps (graph::GraphExecutor, gpu::GpuTimer). Per frame it runs
//
//   floor.shadowed.light<i>.shadow_map   each light's depth-only map, drawn from the light
//                                        by render::ShadowMap at the config's resolution
//                                        with the hard technique's projection and bias
//   floor.shadowed.forward               depth + one RGBA8 target, Lambert, one nearest
//                                        shadow-map compare per light in the fragment shader
//   floor.unshadowed.forward             the same draw without the compares
//
// (the names' prefixes sum to the shadowed and the unshadowed floor frame). Every instance
// is drawn, into every view: no culling, no batching. Not for display: a measuring stick.
#include "penumbra/config/RenderConfig.h"
#include "penumbra/frame/BaseColorPipelines.h"
#include "penumbra/frame/FrameRenderer.h"
#include "penumbra/gpu/Context.h"
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/gpu/Resources.h"
#include "penumbra/gpu/ShaderCompiler.h"
#include "penumbra/graph/GraphExecutor.h"
#include "penumbra/graph/RenderGraph.h"
#include "penumbra/render/Casters.h"
#include "penumbra/render/SceneGpu.h"
#include "penumbra/render/ShadowMap.h"

#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra::frame {

// Pass names, and the prefixes whose passes make up each floor frame.
inline constexpr std::string_view kFloorShadowedPrefix = "floor.shadowed.";
inline constexpr std::string_view kFloorUnshadowedPrefix = "floor.unshadowed.";
inline constexpr std::string_view kFloorShadowedForward = "floor.shadowed.forward";
inline constexpr std::string_view kFloorUnshadowedForward = "floor.unshadowed.forward";
std::string floorShadowMapPass(size_t light);  // "floor.shadowed.light<i>.shadow_map"

// Texels per side of a light's floor map when its config names no "resolution": the hard
// technique's default.
inline constexpr uint32_t kFloorDefaultShadowResolution = 2048;

class FloorRenderer {
public:
    // Builds the floor's graph for `config` (1 to config::kMaxLights lights) over `scene`,
    // which must outlive the renderer. Throws penumbra::ConfigError for a light's
    // "resolution" that is no whole number in [16, the device's largest image].
    FloorRenderer(gpu::Context& context, const scene::Scene& scene, const config::RenderConfig& config);
    ~FloorRenderer();
    FloorRenderer(const FloorRenderer&) = delete;
    FloorRenderer& operator=(const FloorRenderer&) = delete;

    // An animated frame's camera, lights and moved nodes, as FrameRenderer::update takes them.
    void update(const config::RenderConfig& config, const scene::Scene& scene,
                const std::vector<uint32_t>& movedInstances);

    // Runs the floor's passes once and waits; returns their times.
    FrameTimings renderFrame();

    uint32_t width() const { return width_; }
    uint32_t height() const { return height_; }
    uint32_t shadowResolution(size_t light) const { return shadowMaps_.at(light)->resolution(); }

    // After renderFrame(): the shadowed or the unshadowed forward image, sRGB RGBA8 rows,
    // top row first.
    std::vector<uint8_t> readColor(bool shadowed) const;

private:
    void updateLights(const config::RenderConfig& config, const scene::Aabb& sceneBounds);
    void buildGraph();
    void recordForward(graph::PassContext& pass, bool shadowed);

    gpu::Context& context_;
    const scene::Scene& scene_;
    gpu::ShaderCompiler compiler_;
    uint32_t width_ = 0;
    uint32_t height_ = 0;
    glm::mat4 cameraViewProj_{1.0f};
    render::SceneGpu sceneGpu_;
    render::Casters casters_;  // no culling: every caster
    std::vector<scene::Light> lights_;
    std::vector<std::unique_ptr<render::ShadowMap>> shadowMaps_;
    gpu::Buffer lightBuffer_;      // shaders/common/light.glsl, one row per light
    gpu::Buffer shadowMapBuffer_;  // render::ShadowMapData per light (SHADOW_MAP_ARRAY)
    BaseColorPipelines shadowed_;
    BaseColorPipelines unshadowed_;
    gpu::Sampler compareSampler_;
    std::unique_ptr<graph::RenderGraph> graph_;
    graph::GraphExecutor executor_;
};

} // namespace penumbra::frame
