#include "penumbra/frame/SceneResources.h"

#include "frame/FrameFormats.h"
#include "penumbra/plugin/GBuffer.h"
#include "visibility/Visibility.h"

#include <fmt/format.h>

namespace penumbra::frame {
namespace {


BaseColorPipelines makeGBufferPipelines(gpu::Context& context, const gpu::ShaderCompiler& shaders,
                                        const render::SceneGpu& sceneGpu)
{
    gpu::GraphicsPipelineDesc g;
    g.name = "gbuffer";
    g.vertexShader = "engine/gbuffer.vert";
    g.fragmentShader = "engine/gbuffer.frag";
    g.pushConstantBytes = sizeof(glm::mat4);
    g.vertexLayout = {sceneGpu.vertexStride(),
                      {{0, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(scene::Vertex, position)},
                       {1, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(scene::Vertex, normal)},
                       {2, 0, VK_FORMAT_R32G32_SFLOAT, offsetof(scene::Vertex, uv)}}};
    g.colorFormats = {kGBufferNormalFormat, kGBufferAlbedoFormat};
    g.depthFormat = kFrameDepthFormat;
    g.depthCompare = VK_COMPARE_OP_GREATER_OR_EQUAL;
    // Open or single-sided geometry (the ground plane seen from below) must still
    // occlude: no culling; the fragment shader flips back-facing normals.
    g.cullMode = VK_CULL_MODE_NONE;
    return BaseColorPipelines(context, shaders, g);
}

// Everything a compute pipeline is made from, as one key.
std::string pipelineKey(const gpu::ComputePipelineDesc& desc)
{
    std::string key = fmt::format("{}|{}|{}", desc.name, desc.shader.string(), desc.pushConstantBytes);
    for (const gpu::ShaderDefine& d : desc.defines) key += fmt::format("|{}={}", d.name, d.value);
    return key + "|" + desc.source;
}

} // namespace

SceneResources::SceneResources(gpu::Context& context, const scene::Scene& scene, render::DrawBatching batching)
    : context_(context),
      scene_(scene),
      batching_(batching),
      engineShaders_({gpu::engineShaderDir()}),
      sceneGpu_(context, scene, batching),
      casters_(sceneGpu_),
      gbufferPipelines_(makeGBufferPipelines(context, engineShaders_, sceneGpu_)),
      nearestSampler_(gpu::createSampler(context, VK_FILTER_NEAREST, VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE)),
      bvh_(std::make_unique<visibility::SceneBvh>(scene))
{
}

void SceneResources::instancesMoved(std::span<const uint32_t> moved)
{
    sceneGpu_.updateInstances(context_, scene_);
    bvh_->instancesMoved(scene_, moved);
}

uint64_t SceneResources::bvhBuilds() const { return 1 + bvh_->rebuilds; }

std::vector<scene::Aabb> SceneResources::instanceBoxesInView(const glm::mat4& viewProj) const
{
    std::vector<uint32_t> visible;
    bvh_->bvh.cullFrustum(scene::frustumFromViewProj(viewProj), visible);
    std::vector<scene::Aabb> boxes;
    boxes.reserve(visible.size());
    for (uint32_t instance : visible) boxes.push_back(scene_.instances[instance].worldBounds);
    return boxes;
}

SceneResources::~SceneResources()
{
    vkDeviceWaitIdle(context_.device());
}

const gpu::ShaderCompiler& SceneResources::pluginShaders(const std::filesystem::path& pluginShaderDir)
{
    auto& shaders = pluginShaders_[pluginShaderDir];
    if (!shaders) {
        shaders = std::make_unique<gpu::ShaderCompiler>(
            std::vector<std::filesystem::path>{pluginShaderDir, gpu::engineShaderDir()});
    }
    return *shaders;
}

std::shared_ptr<visibility::Visibility> SceneResources::visibility(config::CullingMode mode, uint32_t width,
                                                                    uint32_t height, bool focus)
{
    const VisibilityKey key{mode, width, height, focus};
    if (!visibility_ || !(key == visibilityKey_)) {
        visibility_ = std::make_shared<visibility::Visibility>(context_, engineShaders_, scene_, sceneGpu_, *bvh_, mode,
                                                               width, height, focus);
        visibilityKey_ = key;
        ++visibilityBuilds_;
    }
    return visibility_;
}

const gpu::Pipeline& SceneResources::computePipeline(const gpu::ComputePipelineDesc& desc)
{
    const std::string key = pipelineKey(desc);
    auto found = computePipelines_.find(key);
    if (found == computePipelines_.end()) {
        found = computePipelines_.emplace(key, gpu::Pipeline(context_, engineShaders_, desc)).first;
        ++pipelinesMade_;
    }
    return found->second;
}

const plugin::GBufferExport& SceneResources::gbufferExport()
{
    if (!gbufferExport_) gbufferExport_ = std::make_unique<plugin::GBufferExport>(context_, engineShaders_);
    return *gbufferExport_;
}

} // namespace penumbra::frame
