#pragma once
// The reference's second mode, `brute_force` (README.md next to this file): the
// rasterised reference of the soft-shadow papers. One hard shadow map per light sample
// (the points or directions of LightSampler::fixedSample, the same for every pixel),
// each compared with every G-buffer point at its nearest texel with receiver plane bias,
// V = the (solid-angle weighted, for a sphere) mean. Every sample is a hard shadow, so
// with enough samples the image converges to the ray-traced one up to the maps'
// resolution.
#include "LightSampling.h"

#include "penumbra/gpu/Pipeline.h"
#include "penumbra/gpu/Resources.h"
#include "penumbra/plugin/Technique.h"
#include "penumbra/render/ShadowMap.h"

#include <cstdint>
#include <vector>

namespace penumbra::reference {

struct RasterSettings {
    uint32_t samples = 256;         // requested; lights without extent take 1
    uint32_t seed = 1;              // the sample pattern
    uint32_t mapResolution = 512;   // texels per side of each face of each sample's map
};

class RasterReference final : public plugin::Technique {
public:
    // Throws ConfigError naming `map_resolution` when one sample's map does not fit the
    // device's largest image, Error when a shader does not compile.
    RasterReference(const plugin::TechniqueSetup& setup, const RasterSettings& settings);
    RasterReference(const RasterReference&) = delete;
    RasterReference& operator=(const RasterReference&) = delete;

    void update(const scene::Light& light, const scene::Aabb& sceneBounds) override;
    void registerPasses(graph::RenderGraph& graph, const plugin::LightPassIo& io) override;

private:
    // The samples of one batch: a grid of their maps' atlases in one depth image.
    struct Batch {
        uint32_t first = 0, count = 0;
        uint32_t rows = 0;  // of the grid; columns: gridColumns_
    };

    void recordAccumulate(const graph::PassContext& pass, const plugin::LightPassIo& io, const std::string& maps,
                          const std::string& previous, const std::string& sums, const Batch& batch) const;
    void recordResolve(const graph::PassContext& pass, const plugin::LightPassIo& io, const std::string& sums) const;

    gpu::Context& context_;
    const RasterSettings settings_;
    const uint32_t lightIndex_;
    const uint32_t width_, height_;
    const uint32_t sampleCount_;
    // One ShadowMap of the light's shape: its pipelines draw every sample's map
    // (recordDepthMaps), and update() computes each sample's frusta and ShadowMapData.
    render::ShadowMap shape_;
    uint32_t mapsPerBatch_ = 1;
    uint32_t gridColumns_ = 1;
    std::vector<Batch> batches_;
    scene::Light light_;
    // Per sample: the faces' frusta (for drawing) and ShadowMapData in one storage buffer
    // (for the compares; shaders/common/shadow_map.glsl SHADOW_MAP_ARRAY).
    std::vector<std::vector<render::LightFrustum>> sampleFrusta_;
    gpu::Buffer sampleMaps_;
    gpu::Pipeline accumulate_;       // adds a batch to the sums before
    gpu::Pipeline accumulateFirst_;  // the first batch: starts the sums
    gpu::Pipeline resolve_;
    gpu::Sampler compareSampler_;
};

} // namespace penumbra::reference
