#pragma once
// Hard shadow mapping for one light: a depth-only pass from the light (D32_SFLOAT,
// reversed-Z, constant + slope-scaled bias with depthBiasClamp) into one frustum (spot,
// directional) or six cube faces packed 3 x 2 in one atlas (point, rect, disk), then a
// compute pass that compares each G-buffer position against it and writes the light's
// visibility image. The technique-plugin issue moves this into plugins/hard.
#include "penumbra/config/Config.h"
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/gpu/Resources.h"
#include "penumbra/render/Projection.h"
#include "penumbra/render/SceneGpu.h"

#include <memory>
#include <vector>

namespace penumbra::render {

// Pipelines shared by every light that uses hard shadows.
struct HardShadowPipelines {
    HardShadowPipelines(gpu::Context& context, const gpu::ShaderCompiler& compiler, uint32_t vertexStride);
    ~HardShadowPipelines();
    HardShadowPipelines(const HardShadowPipelines&) = delete;
    HardShadowPipelines& operator=(const HardShadowPipelines&) = delete;

    gpu::Context& context;
    gpu::Pipeline depth;        // solid casters: no fragment shader
    gpu::Pipeline depthMasked;  // alpha-masked casters: a fragment shader cuts the holes
    gpu::Pipeline visibility;
    VkSampler compareSampler = VK_NULL_HANDLE;
};

class HardShadow {
public:
    HardShadow(gpu::Context& context, std::shared_ptr<HardShadowPipelines> pipelines,
               const config::LightConfig& light, const scene::Aabb& sceneBounds, uint32_t width, uint32_t height,
               size_t lightIndex);

    // Refits the frusta after the light or the scene moved.
    void update(const scene::Light& light, const scene::Aabb& sceneBounds);

    void recordShadowMap(VkCommandBuffer cmd, const SceneGpu& scene) const;
    void recordVisibility(VkCommandBuffer cmd, const gpu::Image& gPosition) const;

    const gpu::Image& visibility() const { return visibility_; }
    const std::vector<LightFrustum>& frusta() const { return frusta_; }

private:
    static constexpr uint32_t kMaxFaces = 6;

    gpu::Context& context_;
    std::shared_ptr<HardShadowPipelines> pipelines_;
    struct Settings {
        uint32_t resolution = 2048;
        float depthBiasConstant = 4.0f;
        float depthBiasSlope = 2.0f;
        float depthBiasClamp = 0.0f;
    } settings_;
    uint32_t faceCount_ = 1;
    glm::vec3 lightPosition_{0.0f};
    std::vector<LightFrustum> frusta_;
    gpu::Image shadowMap_;
    gpu::Image visibility_;
    gpu::Buffer frustumBuffer_;  // the faces' view-projection matrices, for the visibility pass
};

} // namespace penumbra::render
