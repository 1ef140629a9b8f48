#pragma once
// What a frame needs that depends only on the scene and the device, not on a
// configuration of it: the scene on the GPU (render::SceneGpu), the casters techniques
// draw, the visibility service with its BVH, the shader compilers (the engine's and one
// per plugin folder, behind the SPIR-V cache) and the engine's pipelines. One of these
// outlives every FrameRenderer drawn over the scene: the viewer's edits, bench's variants
// and compare's techniques build a new configuration on it, so that an edit costs what it
// changes (a technique's passes, the graph), not the scene's upload, the BVH and every
// shader again.
#include "penumbra/config/RenderConfig.h"
#include "penumbra/frame/BaseColorPipelines.h"
#include "penumbra/gpu/Context.h"
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/gpu/Resources.h"
#include "penumbra/gpu/ShaderCompiler.h"
#include "penumbra/render/Casters.h"
#include "penumbra/render/SceneGpu.h"

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace penumbra::visibility {
class Visibility;  // private to the engine (engine/src/visibility/)
struct SceneBvh;
}

namespace penumbra::plugin {
class GBufferExport;
}

namespace penumbra::frame {

class SceneResources {
public:
    // `scene` must outlive the resources (animated frames move its nodes in place).
    SceneResources(gpu::Context& context, const scene::Scene& scene, render::DrawBatching batching);
    ~SceneResources();
    SceneResources(const SceneResources&) = delete;
    SceneResources& operator=(const SceneResources&) = delete;

    // The batching a config asks for ("draw_batching").
    static render::DrawBatching batchingOf(const config::RenderConfig& config)
    {
        return config.batchDraws ? render::DrawBatching::Batched : render::DrawBatching::PerInstance;
    }

    gpu::Context& context() const { return context_; }
    const scene::Scene& scene() const { return scene_; }
    render::DrawBatching batching() const { return batching_; }
    render::SceneGpu& sceneGpu() { return sceneGpu_; }
    render::Casters& casters() { return casters_; }

    // The engine's shaders/ folder.
    const gpu::ShaderCompiler& engineShaders() const { return engineShaders_; }
    // A plugin's shader folder first, then the engine's: one compiler per folder.
    const gpu::ShaderCompiler& pluginShaders(const std::filesystem::path& pluginShaderDir);

    // The visibility service for an output of `width` x `height` culled with `mode` (with
    // focusing when `focus`): the one made last when it matches, else a new one over the
    // scene's BVH, which a renderer holds as long as it draws.
    std::shared_ptr<visibility::Visibility> visibility(config::CullingMode mode, uint32_t width, uint32_t height,
                                                       bool focus);

    // The G-buffer pass's pipelines (engine/gbuffer.*).
    BaseColorPipelines& gbufferPipelines() { return gbufferPipelines_; }
    // A compute pipeline of the engine's shaders, made on first use for each name, shader
    // and defines (the shading pass per layout of the lights' visibility images).
    const gpu::Pipeline& computePipeline(const gpu::ComputePipelineDesc& desc);
    VkSampler nearestSampler() const { return nearestSampler_; }
    // Exports the G-buffer's positions and normals (readPositions, readNormals), made at
    // the first read-back.
    const plugin::GBufferExport& gbufferExport();

    // Instances moved (Scene::updateTransforms, an animated frame): the upload's instance
    // table and the BVH (refit, or rebuilt) follow them.
    void instancesMoved(std::span<const uint32_t> moved);

    // The world boxes of the instances in the view frustum of `viewProj` (the BVH's
    // query): what the camera may see, for deciding which lights can matter.
    std::vector<scene::Aabb> instanceBoxesInView(const glm::mat4& viewProj) const;

    // Figures for tests: visibility services made, the BVH's builds (one, and one per
    // rebuild after a move), compute pipelines made.
    uint32_t visibilityBuilds() const { return visibilityBuilds_; }
    uint64_t bvhBuilds() const;
    uint32_t pipelinesMade() const { return pipelinesMade_; }

private:
    struct VisibilityKey {
        config::CullingMode mode;
        uint32_t width, height;
        bool focus;
        bool operator==(const VisibilityKey&) const = default;
    };

    gpu::Context& context_;
    const scene::Scene& scene_;
    render::DrawBatching batching_;
    gpu::ShaderCompiler engineShaders_;
    std::map<std::filesystem::path, std::unique_ptr<gpu::ShaderCompiler>> pluginShaders_;
    render::SceneGpu sceneGpu_;
    render::Casters casters_;
    BaseColorPipelines gbufferPipelines_;
    gpu::Sampler nearestSampler_;
    std::map<std::string, gpu::Pipeline> computePipelines_;
    std::unique_ptr<visibility::SceneBvh> bvh_;  // before the services that read it
    VisibilityKey visibilityKey_{};
    std::shared_ptr<visibility::Visibility> visibility_;
    std::unique_ptr<plugin::GBufferExport> gbufferExport_;
    uint32_t visibilityBuilds_ = 0;
    uint32_t pipelinesMade_ = 0;
};

} // namespace penumbra::frame
