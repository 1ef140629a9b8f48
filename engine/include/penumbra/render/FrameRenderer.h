#pragma once
// One frame, end to end (DESIGN.md): G-buffer -> per light: shadow technique passes ->
// visibility image V_l -> shading -> colour image. The foundation's fixed pipeline; the
// pass scheduler and technique plugins of later issues take over its middle part.
#include "penumbra/config/Config.h"
#include "penumbra/gpu/Context.h"
#include "penumbra/gpu/GpuTimer.h"
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/gpu/Resources.h"
#include "penumbra/gpu/ShaderCompiler.h"
#include "penumbra/render/Projection.h"
#include "penumbra/render/SceneGpu.h"

#include <memory>
#include <string>
#include <vector>

namespace penumbra::render {

struct PassTiming {
    std::string name;
    double gpuMs = 0.0;
    double cpuMs = 0.0;  // recording time on the CPU
};

struct FrameTimings {
    std::vector<PassTiming> passes;
    double frameCpuMs = 0.0;  // record + submit + wait, wall clock
};

class HardShadow;

class FrameRenderer {
public:
    FrameRenderer(gpu::Context& context, const scene::Scene& scene, const config::RenderConfig& config);
    ~FrameRenderer();
    FrameRenderer(const FrameRenderer&) = delete;
    FrameRenderer& operator=(const FrameRenderer&) = delete;

    // Takes the camera, the lights and moved scene nodes of an animated frame: call it
    // after config::applyAnimation and scene.updateTransforms(), before renderFrame().
    // `movedInstances` is what updateTransforms() returned.
    void update(const config::RenderConfig& config, const scene::Scene& scene,
                const std::vector<uint32_t>& movedInstances);

    // Records, submits and waits for one frame; returns the time of every pass.
    FrameTimings renderFrame();

    uint32_t width() const { return width_; }
    uint32_t height() const { return height_; }
    size_t lightCount() const;
    // The light's first shadow frustum (its only one, except for cube-mapped lights).
    const LightFrustum& lightFrustum(size_t light) const;
    const std::vector<LightFrustum>& lightFrusta(size_t light) const;
    const glm::mat4& cameraViewProj() const { return cameraViewProj_; }

    // Read-back after renderFrame(): sRGB RGBA8 rows, top row first.
    std::vector<uint8_t> readColor() const;
    // V_l, one float per pixel.
    std::vector<float> readVisibility(size_t light) const;
    // G-buffer world positions, four floats per pixel (w = 0 where no geometry).
    std::vector<float> readPositions() const;
    // G-buffer world normals, four floats per pixel.
    std::vector<float> readNormals() const;

private:
    void updateLights(const config::RenderConfig& config, const scene::Aabb& sceneBounds);
    void recordGBuffer(VkCommandBuffer cmd);
    void recordShading(VkCommandBuffer cmd);
    template <class F>
    void timedPass(VkCommandBuffer cmd, const std::string& name, FrameTimings& timings, F&& record);

    gpu::Context& context_;
    gpu::ShaderCompiler compiler_;
    uint32_t width_ = 0;
    uint32_t height_ = 0;
    glm::mat4 cameraViewProj_{1.0f};
    glm::vec4 ambient_{0.0f};
    glm::vec4 background_{0.0f};

    SceneGpu sceneGpu_;
    gpu::Image gPosition_;
    gpu::Image gNormal_;
    gpu::Image gAlbedo_;
    gpu::Image gDepth_;
    gpu::Image color_;
    gpu::Buffer lightBuffer_;
    gpu::Pipeline gbufferPipeline_;
    gpu::Pipeline shadingPipeline_;
    VkSampler nearestSampler_ = VK_NULL_HANDLE;
    std::vector<std::unique_ptr<HardShadow>> shadows_;
    gpu::GpuTimer timer_;
    VkCommandBuffer cmd_ = VK_NULL_HANDLE;
};

} // namespace penumbra::render
