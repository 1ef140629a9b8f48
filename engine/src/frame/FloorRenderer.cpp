#include "penumbra/frame/FloorRenderer.h"

#include "core/Clock.h"
#include "frame/FrameFormats.h"
#include "frame/LightTable.h"
#include "penumbra/core/Error.h"
#include "penumbra/core/ShortText.h"
#include "penumbra/graph/PassContext.h"
#include "penumbra/render/Projection.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>

namespace penumbra::frame {
namespace {


// The graph's images: one colour and one depth target per forward draw (both are read
// back, so neither is aliased with the other).
constexpr const char* kShadowedColor = "floor.shadowed.color";
constexpr const char* kShadowedDepth = "floor.shadowed.depth";
constexpr const char* kUnshadowedColor = "floor.unshadowed.color";
constexpr const char* kUnshadowedDepth = "floor.unshadowed.depth";

// The hard technique's default rasterizer bias (plugins/hard: depth_bias 4, slope_bias 2
// for its one-texel compare): the floor's compare is that technique's default lookup.
constexpr render::ShadowDepthBias kFloorBias{4.0f, 2.0f, 0.0f};

struct ForwardPush {
    glm::mat4 viewProj;
    glm::vec4 ambient;
};

// The sRGB encoding of a linear colour (what the forward shader writes for surfaces),
// for the background clear.
float linearToSrgb(float c)
{
    c = std::clamp(c, 0.0f, 1.0f);
    return c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
}

// The map resolution the config gives light `index`, or the default.
uint32_t floorResolution(const config::LightConfig& light, size_t index)
{
    const nlohmann::json* value = light.shadow.param("resolution");
    if (!value) return kFloorDefaultShadowResolution;
    if (!value->is_number_integer() || value->get<int64_t>() < 16 || value->get<int64_t>() > (int64_t(1) << 16)) {
        const auto where = std::find_if(light.shadow.params.begin(), light.shadow.params.end(),
                                        [](const config::ShadowParam& p) { return p.name == "resolution"; });
        throw ConfigError(fmt::format("{}: floor of light {}: resolution must be a whole number in [16, 65536], got {}",
                                      where->where, index, core::shortJson(*value)));
    }
    return uint32_t(value->get<int64_t>());
}

} // namespace

std::string floorShadowMapPass(size_t light) { return fmt::format("{}light{}.shadow_map", kFloorShadowedPrefix, light); }

FloorRenderer::FloorRenderer(gpu::Context& context, const scene::Scene& scene, const config::RenderConfig& config)
    : context_(context),
      scene_(scene),
      compiler_({gpu::engineShaderDir()}),
      width_(config.width),
      height_(config.height),
      sceneGpu_(context, scene),
      casters_(sceneGpu_),
      lightBuffer_(context, sizeof(LightData) * config::kMaxLights, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true,
                   "floor.lights"),
      shadowMapBuffer_(context, sizeof(render::ShadowMapData) * config::kMaxLights, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                       true, "floor.shadow_maps"),
      executor_(context)
{
    if (config.lights.empty() || config.lights.size() > config::kMaxLights) {
        throw Error(fmt::format("floor: {} lights: expected 1 to {}", config.lights.size(), config::kMaxLights));
    }
    lights_.resize(config.lights.size());
    for (size_t i = 0; i < config.lights.size(); ++i) {
        lights_[i] = config.lights[i].light;
        const render::ShadowMapSetup setup{context_, compiler_, casters_, lights_[i], scene.bounds(), uint32_t(i)};
        shadowMaps_.push_back(
            std::make_unique<render::ShadowMap>(setup, floorResolution(config.lights[i], i), "floor"));
    }

    gpu::GraphicsPipelineDesc d;
    d.name = "floor.shadowed.forward";
    d.vertexShader = "engine/floor_forward.vert";
    d.fragmentShader = "engine/floor_forward.frag";
    d.defines = {{"LIGHT_COUNT", std::to_string(lights_.size())}, {"SHADOWED", "1"}};
    d.pushConstantBytes = sizeof(ForwardPush);
    d.vertexLayout = {sceneGpu_.vertexStride(),
                      {{0, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(scene::Vertex, position)},
                       {1, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(scene::Vertex, normal)},
                       {2, 0, VK_FORMAT_R32G32_SFLOAT, offsetof(scene::Vertex, uv)}}};
    d.colorFormats = {kFrameColorFormat};
    d.depthFormat = kFrameDepthFormat;
    d.depthCompare = VK_COMPARE_OP_GREATER_OR_EQUAL;
    d.cullMode = VK_CULL_MODE_NONE;  // as the G-buffer: open geometry seen from behind still occludes
    shadowed_ = BaseColorPipelines(context_, compiler_, d);
    d.name = "floor.unshadowed.forward";
    d.defines = {{"LIGHT_COUNT", std::to_string(lights_.size())}, {"SHADOWED", "0"}};
    unshadowed_ = BaseColorPipelines(context_, compiler_, d);
    compareSampler_ = render::createShadowCompareSampler(context_);

    update(config, scene, {});
    buildGraph();
}

FloorRenderer::~FloorRenderer() { vkDeviceWaitIdle(context_.device()); }

void FloorRenderer::update(const config::RenderConfig& config, const scene::Scene& scene,
                           const std::vector<uint32_t>& movedInstances)
{
    if (config.lights.size() != lights_.size()) {
        throw Error(fmt::format("FloorRenderer::update: {} lights, the floor was built for {}", config.lights.size(),
                                lights_.size()));
    }
    if (&scene != &scene_) throw Error("FloorRenderer::update: called with another scene than the floor was built with");
    cameraViewProj_ = render::cameraViewProj(config.camera, float(width_) / float(height_));
    if (!movedInstances.empty()) sceneGpu_.updateInstances(context_, scene);
    auto* maps = static_cast<render::ShadowMapData*>(shadowMapBuffer_.mapped());
    for (size_t i = 0; i < lights_.size(); ++i) {
        lights_[i] = config.lights[i].light;
        shadowMaps_[i]->update(lights_[i], scene.bounds());
        maps[i] = shadowMaps_[i]->data();
    }
    writeLightTable(lights_, static_cast<LightData*>(lightBuffer_.mapped()));
}

void FloorRenderer::buildGraph()
{
    graph_ = std::make_unique<graph::RenderGraph>();
    graph::RenderGraph& g = *graph_;
    for (size_t i = 0; i < shadowMaps_.size(); ++i) shadowMaps_[i]->addDepthPass(g, floorShadowMapPass(i), kFloorBias);
    g.declareImage({kShadowedColor, width_, height_, kFrameColorFormat});
    g.declareImage({kShadowedDepth, width_, height_, kFrameDepthFormat});
    g.declareImage({kUnshadowedColor, width_, height_, kFrameColorFormat});
    g.declareImage({kUnshadowedDepth, width_, height_, kFrameDepthFormat});
    graph::PassBuilder shadowed = g.addPass(std::string(kFloorShadowedForward), graph::QueueKind::Graphics);
    shadowed.write(kShadowedColor, graph::Usage::ColorAttachment)
        .write(kShadowedDepth, graph::Usage::DepthAttachment)
        .execute([this](graph::PassContext& pass) { recordForward(pass, true); });
    for (size_t i = 0; i < shadowMaps_.size(); ++i) shadowed.read(floorShadowMapPass(i), graph::Usage::Sampled);
    g.addPass(std::string(kFloorUnshadowedForward), graph::QueueKind::Graphics)
        .write(kUnshadowedColor, graph::Usage::ColorAttachment)
        .write(kUnshadowedDepth, graph::Usage::DepthAttachment)
        .execute([this](graph::PassContext& pass) { recordForward(pass, false); });
    g.markOutput(kShadowedColor);
    g.markOutput(kUnshadowedColor);
    g.compile();
}

FrameTimings FloorRenderer::renderFrame()
{
    const auto start = std::chrono::steady_clock::now();
    FrameTimings timings;
    executor_.execute(*graph_);
    timings.passes = executor_.collectTimings();
    timings.frameCpuMs = core::msSince(start);
    return timings;
}

void FloorRenderer::recordForward(graph::PassContext& pass, bool shadowed)
{
    const VkCommandBuffer cmd = pass.cmd();
    VkRenderingAttachmentInfo color{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
    color.imageView = pass.image(shadowed ? kShadowedColor : kUnshadowedColor).view();
    color.imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    color.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
    color.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    color.clearValue.color = {{linearToSrgb(kBackground.r), linearToSrgb(kBackground.g), linearToSrgb(kBackground.b), 1.0f}};
    VkRenderingAttachmentInfo depth{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
    depth.imageView = pass.image(shadowed ? kShadowedDepth : kUnshadowedDepth).view();
    depth.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
    depth.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
    depth.storeOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;  // a forward engine needs no depth after the draw
    depth.clearValue.depthStencil = {0.0f, 0};          // reversed-Z
    VkRenderingInfo info{VK_STRUCTURE_TYPE_RENDERING_INFO};
    info.renderArea = {{0, 0}, {width_, height_}};
    info.layerCount = 1;
    info.colorAttachmentCount = 1;
    info.pColorAttachments = &color;
    info.pDepthAttachment = &depth;
    vkCmdBeginRendering(cmd, &info);
    const VkViewport viewport{0.0f, 0.0f, float(width_), float(height_), 0.0f, 1.0f};
    const VkRect2D scissor{{0, 0}, {width_, height_}};
    vkCmdSetViewport(cmd, 0, 1, &viewport);
    vkCmdSetScissor(cmd, 0, 1, &scissor);
    BaseColorPipelines& pipelines = shadowed ? shadowed_ : unshadowed_;
    pipelines.begin();
    const ForwardPush push{cameraViewProj_, kSkyAmbient};
    std::vector<const gpu::Image*> maps;
    if (shadowed) {
        for (size_t i = 0; i < shadowMaps_.size(); ++i) maps.push_back(&pass.image(floorShadowMapPass(i)));
    }
    sceneGpu_.draw(cmd, render::DrawFilter::All, [&](const gpu::Image& texture) {
        const gpu::Pipeline& pipeline = pipelines.bindFor(cmd, sceneGpu_, texture, &push, sizeof(push));
        gpu::DescriptorPush descriptors;
        descriptors.storageBuffer("Instances", sceneGpu_.instanceBuffer())
            .storageBuffer("Materials", sceneGpu_.materialBuffer())
            .storageBuffer("Lights", lightBuffer_);
        if (pipelines.textured(pipeline))
            descriptors.sampledImage("baseColorTexture", texture, sceneGpu_.textureSampler());
        if (shadowed) {
            descriptors.sampledImages("shadowMaps", maps, compareSampler_, pass.layout(floorShadowMapPass(0)))
                .storageBuffer("ShadowMapArrayBuffer", shadowMapBuffer_);
        }
        descriptors.push(context_, cmd, pipeline);
    });
    vkCmdEndRendering(cmd);
}

std::vector<uint8_t> FloorRenderer::readColor(bool shadowed) const
{
    const char* name = shadowed ? kShadowedColor : kUnshadowedColor;
    const std::vector<std::byte> bytes = gpu::readImage(context_, executor_.image(name), executor_.finalLayout(name));
    std::vector<uint8_t> out(bytes.size());
    std::memcpy(out.data(), bytes.data(), bytes.size());
    return out;
}

} // namespace penumbra::frame
