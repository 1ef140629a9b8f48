#pragma once
// Hard shadow mapping for one spot light: a depth-only pass from the light (D32_SFLOAT,
// reversed-Z, constant + slope-scaled bias with depthBiasClamp), then a compute pass
// that compares each G-buffer position against it and writes the light's visibility
// image. The technique-plugin issue moves this into plugins/hard.
#include "penumbra/config/Config.h"
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/gpu/Resources.h"
#include "penumbra/render/Projection.h"
#include "penumbra/render/SceneGpu.h"

namespace penumbra::render {

// Pipelines shared by every light that uses hard shadows.
struct HardShadowPipelines {
    HardShadowPipelines(gpu::Context& context, const gpu::ShaderCompiler& compiler, uint32_t vertexStride);
    ~HardShadowPipelines();
    HardShadowPipelines(const HardShadowPipelines&) = delete;
    HardShadowPipelines& operator=(const HardShadowPipelines&) = delete;

    gpu::Context& context;
    gpu::Pipeline depth;
    gpu::Pipeline visibility;
    VkSampler compareSampler = VK_NULL_HANDLE;
};

class HardShadow {
public:
    HardShadow(gpu::Context& context, std::shared_ptr<HardShadowPipelines> pipelines,
               const config::LightConfig& light, const scene::Aabb& sceneBounds, uint32_t width, uint32_t height,
               size_t lightIndex);

    void recordShadowMap(VkCommandBuffer cmd, const SceneGpu& scene) const;
    void recordVisibility(VkCommandBuffer cmd, const gpu::Image& gPosition) const;

    const gpu::Image& visibility() const { return visibility_; }
    const LightFrustum& frustum() const { return frustum_; }

private:
    gpu::Context& context_;
    std::shared_ptr<HardShadowPipelines> pipelines_;
    config::ShadowSettings settings_;
    LightFrustum frustum_;
    gpu::Image shadowMap_;
    gpu::Image visibility_;
};

} // namespace penumbra::render
