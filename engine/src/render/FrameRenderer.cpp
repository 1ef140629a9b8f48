#include "penumbra/render/FrameRenderer.h"

#include "HardShadow.h"
#include "penumbra/core/Error.h"
#include "penumbra/gpu/Barrier.h"
#include "penumbra/gpu/Check.h"

#include <fmt/format.h>

#include <chrono>
#include <cstring>

namespace penumbra::render {
namespace {

constexpr VkFormat kPositionFormat = VK_FORMAT_R32G32B32A32_SFLOAT;
constexpr VkFormat kNormalFormat = VK_FORMAT_R16G16B16A16_SFLOAT;
constexpr VkFormat kAlbedoFormat = VK_FORMAT_R8G8B8A8_UNORM;
constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;
constexpr VkFormat kColorFormat = VK_FORMAT_R8G8B8A8_UNORM;

struct LightData {  // matches shaders/common/light.glsl
    glm::vec4 positionWorld;
    glm::vec4 direction;
    glm::vec4 radiance;
};

struct ShadingPush {
    glm::vec4 ambient;
    glm::vec4 background;
};

double msSince(std::chrono::steady_clock::time_point start)
{
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

gpu::Image gbufferImage(gpu::Context& context, uint32_t w, uint32_t h, VkFormat format, const char* name)
{
    return gpu::Image(context, {w, h, format,
                                VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_STORAGE_BIT |
                                    VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                                name});
}

} // namespace

FrameRenderer::FrameRenderer(gpu::Context& context, const scene::Scene& scene, const config::RenderConfig& config)
    : context_(context),
      compiler_({gpu::engineShaderDir()}),
      width_(config.width),
      height_(config.height),
      sceneGpu_(context, scene),
      gPosition_(gbufferImage(context, width_, height_, kPositionFormat, "gbuffer.position")),
      gNormal_(gbufferImage(context, width_, height_, kNormalFormat, "gbuffer.normal")),
      gAlbedo_(gbufferImage(context, width_, height_, kAlbedoFormat, "gbuffer.albedo")),
      gDepth_(context, {width_, height_, kDepthFormat, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT, "gbuffer.depth"}),
      color_(context, {width_, height_, kColorFormat, VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                       "color"}),
      lightBuffer_(context, sizeof(LightData) * config::kMaxLights, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true, "lights"),
      timer_(context, 2 + 2 * config::kMaxLights)
{
    if (config.lights.empty() || config.lights.size() > config::kMaxLights) {
        throw Error(fmt::format("{} lights: expected 1 to {}", config.lights.size(), config::kMaxLights));
    }
    cameraViewProj_ = render::cameraViewProj(config.camera, float(width_) / float(height_));
    ambient_ = {0.035f, 0.04f, 0.05f, 1.0f};
    background_ = {0.55f, 0.65f, 0.8f, 1.0f};

    gpu::GraphicsPipelineDesc g;
    g.name = "gbuffer";
    g.vertexShader = "engine/gbuffer.vert";
    g.fragmentShader = "engine/gbuffer.frag";
    g.bindings = {{0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},
                  {1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},
                  {2, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER}};
    g.pushConstantBytes = sizeof(glm::mat4);
    g.vertexLayout = {sceneGpu_.vertexStride(),
                      {{0, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(scene::Vertex, position)},
                       {1, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(scene::Vertex, normal)},
                       {2, 0, VK_FORMAT_R32G32_SFLOAT, offsetof(scene::Vertex, uv)}}};
    g.colorFormats = {kPositionFormat, kNormalFormat, kAlbedoFormat};
    g.depthFormat = kDepthFormat;
    g.depthCompare = VK_COMPARE_OP_GREATER_OR_EQUAL;
    // Open or single-sided geometry (the ground plane seen from below) must still
    // occlude: no culling; the fragment shader flips back-facing normals.
    g.cullMode = VK_CULL_MODE_NONE;
    gbufferPipeline_ = gpu::Pipeline(context, compiler_, g);

    gpu::ComputePipelineDesc s;
    s.name = "shading";
    s.shader = "engine/shading.comp";
    s.defines = {{"LIGHT_COUNT", std::to_string(config.lights.size())}};
    s.bindings = {{0, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE},
                  {1, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE},
                  {2, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE},
                  {3, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, static_cast<uint32_t>(config.lights.size())},
                  {4, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER},
                  {5, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE}};
    s.pushConstantBytes = sizeof(ShadingPush);
    shadingPipeline_ = gpu::Pipeline(context, compiler_, s);
    nearestSampler_ = gpu::createSampler(context, VK_FILTER_NEAREST, VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE);

    const scene::Aabb bounds = scene.bounds();
    auto pipelines = std::make_shared<HardShadowPipelines>(context, compiler_, sceneGpu_.vertexStride());
    for (size_t i = 0; i < config.lights.size(); ++i) {
        shadows_.push_back(std::make_unique<HardShadow>(context, pipelines, config.lights[i], bounds, width_, height_, i));
    }
    updateLights(config, bounds);

    VkCommandBufferAllocateInfo alloc{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
    alloc.commandPool = context.commandPool();
    alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    alloc.commandBufferCount = 1;
    gpu::check(vkAllocateCommandBuffers(context.device(), &alloc, &cmd_), "vkAllocateCommandBuffers (frame)");
}

FrameRenderer::~FrameRenderer()
{
    vkDeviceWaitIdle(context_.device());
    vkFreeCommandBuffers(context_.device(), context_.commandPool(), 1, &cmd_);
    vkDestroySampler(context_.device(), nearestSampler_, nullptr);
}

size_t FrameRenderer::lightCount() const { return shadows_.size(); }

const LightFrustum& FrameRenderer::lightFrustum(size_t light) const { return shadows_.at(light)->frusta().front(); }

const std::vector<LightFrustum>& FrameRenderer::lightFrusta(size_t light) const { return shadows_.at(light)->frusta(); }

void FrameRenderer::update(const config::RenderConfig& config, const scene::Scene& scene,
                           const std::vector<uint32_t>& movedInstances)
{
    if (config.lights.size() != shadows_.size()) {
        throw Error(fmt::format("FrameRenderer::update: {} lights, the renderer was built for {}", config.lights.size(),
                                shadows_.size()));
    }
    cameraViewProj_ = render::cameraViewProj(config.camera, float(width_) / float(height_));
    if (!movedInstances.empty()) sceneGpu_.updateInstances(context_, scene);
    updateLights(config, scene.bounds());
}

void FrameRenderer::updateLights(const config::RenderConfig& config, const scene::Aabb& sceneBounds)
{
    static_assert(int(scene::LightType::Directional) == 0 && int(scene::LightType::Spot) == 1 &&
                      int(scene::LightType::Point) == 2 && int(scene::LightType::Rect) == 3 &&
                      int(scene::LightType::Disk) == 4,
                  "type codes in shaders/common/light.glsl");
    auto* lights = static_cast<LightData*>(lightBuffer_.mapped());
    for (size_t i = 0; i < config.lights.size(); ++i) {
        const scene::Light& l = config.lights[i].light;
        lights[i].positionWorld = glm::vec4(l.position, float(int(l.type)));
        lights[i].direction = glm::vec4(glm::normalize(l.direction), std::cos(glm::radians(l.outerConeDeg)));
        lights[i].radiance = glm::vec4(l.color * l.intensity, std::cos(glm::radians(l.innerConeDeg)));
        shadows_[i]->update(l, sceneBounds);
    }
}

template <class F>
void FrameRenderer::timedPass(VkCommandBuffer cmd, const std::string& name, FrameTimings& timings, F&& record)
{
    const auto start = std::chrono::steady_clock::now();
    context_.beginLabel(cmd, name);
    const uint32_t scope = timer_.beginScope(cmd, name);
    record();
    timer_.endScope(cmd, scope);
    context_.endLabel(cmd);
    timings.passes.push_back({name, 0.0, msSince(start)});
}

FrameTimings FrameRenderer::renderFrame()
{
    const auto frameStart = std::chrono::steady_clock::now();
    FrameTimings timings;
    gpu::check(vkResetCommandBuffer(cmd_, 0), "vkResetCommandBuffer (frame)");
    VkCommandBufferBeginInfo begin{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    gpu::check(vkBeginCommandBuffer(cmd_, &begin), "vkBeginCommandBuffer (frame)");
    timer_.beginFrame(cmd_);

    timedPass(cmd_, "gbuffer", timings, [&] { recordGBuffer(cmd_); });
    for (size_t i = 0; i < shadows_.size(); ++i) {
        const HardShadow& shadow = *shadows_[i];
        timedPass(cmd_, fmt::format("light{}.hard.shadow_map", i), timings,
                  [&] { shadow.recordShadowMap(cmd_, sceneGpu_); });
        timedPass(cmd_, fmt::format("light{}.hard.visibility", i), timings,
                  [&] { shadow.recordVisibility(cmd_, gPosition_); });
    }
    timedPass(cmd_, "shading", timings, [&] { recordShading(cmd_); });
    gpu::check(vkEndCommandBuffer(cmd_), "vkEndCommandBuffer (frame)");

    context_.submitAndWait(cmd_);

    const std::vector<gpu::ScopeTime> gpuTimes = timer_.collect();
    for (size_t i = 0; i < gpuTimes.size() && i < timings.passes.size(); ++i) {
        timings.passes[i].gpuMs = gpuTimes[i].gpuMs;
    }
    timings.frameCpuMs = msSince(frameStart);
    return timings;
}

void FrameRenderer::recordGBuffer(VkCommandBuffer cmd)
{
    for (const gpu::Image* image : {&gPosition_, &gNormal_, &gAlbedo_}) {
        gpu::transition(cmd, *image, gpu::access::kUndefined, gpu::access::kColorAttachment);
    }
    gpu::transition(cmd, gDepth_, gpu::access::kUndefined, gpu::access::kDepthAttachment);

    VkRenderingAttachmentInfo colors[3];
    const gpu::Image* targets[3] = {&gPosition_, &gNormal_, &gAlbedo_};
    for (int i = 0; i < 3; ++i) {
        colors[i] = {VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
        colors[i].imageView = targets[i]->view();
        colors[i].imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
        colors[i].loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
        colors[i].storeOp = VK_ATTACHMENT_STORE_OP_STORE;
        colors[i].clearValue.color = {{0.0f, 0.0f, 0.0f, 0.0f}};  // w = 0: no geometry
    }
    VkRenderingAttachmentInfo depth{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
    depth.imageView = gDepth_.view();
    depth.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
    depth.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
    depth.storeOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    depth.clearValue.depthStencil = {0.0f, 0};
    VkRenderingInfo info{VK_STRUCTURE_TYPE_RENDERING_INFO};
    info.renderArea = {{0, 0}, {width_, height_}};
    info.layerCount = 1;
    info.colorAttachmentCount = 3;
    info.pColorAttachments = colors;
    info.pDepthAttachment = &depth;
    vkCmdBeginRendering(cmd, &info);
    VkViewport viewport{0.0f, 0.0f, float(width_), float(height_), 0.0f, 1.0f};
    VkRect2D scissor{{0, 0}, {width_, height_}};
    vkCmdSetViewport(cmd, 0, 1, &viewport);
    vkCmdSetScissor(cmd, 0, 1, &scissor);
    gbufferPipeline_.bind(cmd);
    gbufferPipeline_.pushConstants(cmd, &cameraViewProj_, sizeof(glm::mat4));
    sceneGpu_.draw(cmd, DrawFilter::All, [&](const gpu::Image& texture) {
        gpu::DescriptorPush()
            .storageBuffer(0, sceneGpu_.instanceBuffer())
            .storageBuffer(1, sceneGpu_.materialBuffer())
            .sampledImage(2, texture, sceneGpu_.textureSampler())
            .push(context_, cmd, gbufferPipeline_);
    });
    vkCmdEndRendering(cmd);

    for (const gpu::Image* image : targets) {
        gpu::transition(cmd, *image, gpu::access::kColorAttachment, gpu::access::kComputeRead);
    }
}

void FrameRenderer::recordShading(VkCommandBuffer cmd)
{
    gpu::transition(cmd, color_, gpu::access::kUndefined, gpu::access::kComputeWrite);
    std::vector<const gpu::Image*> visibility;
    for (const auto& shadow : shadows_) visibility.push_back(&shadow->visibility());
    shadingPipeline_.bind(cmd);
    gpu::DescriptorPush()
        .storageImage(0, gPosition_)
        .storageImage(1, gNormal_)
        .storageImage(2, gAlbedo_)
        .sampledImages(3, visibility, nearestSampler_)
        .storageBuffer(4, lightBuffer_)
        .storageImage(5, color_)
        .push(context_, cmd, shadingPipeline_);
    const ShadingPush push{ambient_, background_};
    shadingPipeline_.pushConstants(cmd, &push, sizeof(push));
    vkCmdDispatch(cmd, (width_ + 7) / 8, (height_ + 7) / 8, 1);
    gpu::transition(cmd, color_, gpu::access::kComputeWrite, gpu::access::kComputeRead);
}

std::vector<uint8_t> FrameRenderer::readColor() const
{
    const std::vector<std::byte> bytes = gpu::readImage(context_, color_, VK_IMAGE_LAYOUT_GENERAL);
    std::vector<uint8_t> out(bytes.size());
    std::memcpy(out.data(), bytes.data(), bytes.size());
    return out;
}

std::vector<float> FrameRenderer::readVisibility(size_t light) const
{
    return gpu::readImageFloats(context_, shadows_.at(light)->visibility(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
}

std::vector<float> FrameRenderer::readPositions() const
{
    return gpu::readImageFloats(context_, gPosition_, VK_IMAGE_LAYOUT_GENERAL);
}

std::vector<float> FrameRenderer::readNormals() const
{
    return gpu::readImageFloats(context_, gNormal_, VK_IMAGE_LAYOUT_GENERAL);
}

} // namespace penumbra::render
