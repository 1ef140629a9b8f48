#include "penumbra/frame/FrameRenderer.h"

#include "penumbra/core/Error.h"
#include "penumbra/gpu/Barrier.h"
#include "frame/LightTable.h"
#include "penumbra/plugin/Params.h"
#include "visibility/Visibility.h"

#include <fmt/format.h>

#include <chrono>
#include <cstring>

namespace penumbra::frame {
namespace {

constexpr VkFormat kPositionFormat = VK_FORMAT_R32G32B32A32_SFLOAT;
constexpr VkFormat kNormalFormat = VK_FORMAT_R16G16B16A16_SFLOAT;
constexpr VkFormat kAlbedoFormat = VK_FORMAT_R8G8B8A8_UNORM;
constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;
constexpr VkFormat kColorFormat = VK_FORMAT_R8G8B8A8_UNORM;
constexpr VkFormat kVisibilityFormat = VK_FORMAT_R32_SFLOAT;  // shaders/common/visibility.glsl

struct ShadingPush {
    glm::vec4 ambient;
    glm::vec4 background;
};

double msSince(std::chrono::steady_clock::time_point start)
{
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

// Graph names of the engine's images (plugin::LightPassIo refers to the G-buffer ones).
constexpr const char* kGPosition = "gbuffer.position";
constexpr const char* kGNormal = "gbuffer.normal";
constexpr const char* kGAlbedo = "gbuffer.albedo";
constexpr const char* kGDepth = "gbuffer.depth";
constexpr const char* kColor = "color";

} // namespace

FrameRenderer::FrameRenderer(gpu::Context& context, const scene::Scene& scene, const config::RenderConfig& config,
                             plugin::PluginRegistry& plugins)
    : context_(context),
      plugins_(plugins),
      scene_(scene),
      compiler_({gpu::engineShaderDir()}),
      width_(config.width),
      height_(config.height),
      sceneGpu_(context, scene, config.batchDraws ? render::DrawBatching::Batched : render::DrawBatching::PerInstance),
      casters_(sceneGpu_),
      lightBuffer_(context, sizeof(LightData) * config::kMaxLights, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true, "lights"),
      executor_(context)
{
    if (config.lights.empty() || config.lights.size() > config::kMaxLights) {
        throw Error(fmt::format("{} lights: expected 1 to {}", config.lights.size(), config::kMaxLights));
    }
    cameraViewProj_ = render::cameraViewProj(config.camera, float(width_) / float(height_));
    ambient_ = kSkyAmbient;
    background_ = kBackground;

    gpu::GraphicsPipelineDesc g;
    g.name = "gbuffer";
    g.vertexShader = "engine/gbuffer.vert";
    g.fragmentShader = "engine/gbuffer.frag";
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
    s.pushConstantBytes = sizeof(ShadingPush);
    shadingPipeline_ = gpu::Pipeline(context, compiler_, s);
    nearestSampler_ = gpu::createSampler(context, VK_FILTER_NEAREST, VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE);
    visibility_ = std::make_unique<visibility::Visibility>(context, compiler_, scene, sceneGpu_, config.culling, width_,
                                                           height_, config.shadowFocus);
    casters_.setCulling(visibility_.get());

    createTechniques(config, scene);
    updateLights(config, scene.bounds());
    buildGraph();
}

FrameRenderer::~FrameRenderer()
{
    vkDeviceWaitIdle(context_.device());
    // Techniques are plugin code: destroy them (and the graph, whose callbacks they own)
    // while the registry still holds their libraries.
    graph_.reset();
    lights_.clear();
}

void FrameRenderer::createTechniques(const config::RenderConfig& config, const scene::Scene& scene)
{
    lights_.resize(config.lights.size());
    for (size_t i = 0; i < config.lights.size(); ++i) {
        const config::LightConfig& lc = config.lights[i];
        LightSlot& slot = lights_[i];
        slot.visibility = fmt::format("light{}.visibility", i);
        slot.required = lc.shadow.required;
        slot.light = lc.light;
        const std::string who = fmt::format("light {} ('{}')", i, lc.name);
        try {
            slot.plugin = &plugins_.load(lc.shadow.technique);
        } catch (const plugin::PluginError& e) {
            if (slot.required) throw plugin::PluginError(e.kind(), fmt::format("{}: {}", who, e.what()));
            dropTechnique(i, e.what());
            continue;
        }
        // Bad parameter values are the config's fault, not the plugin's: always an error.
        slot.params = std::make_unique<plugin::ParamValues>(plugin::resolveParams(*slot.plugin, lc.shadow));

        auto& shaders = pluginShaders_[lc.shadow.technique];
        if (!shaders) {
            shaders = std::make_unique<gpu::ShaderCompiler>(
                std::vector<std::filesystem::path>{slot.plugin->shaderDir, gpu::engineShaderDir()});
        }
        const plugin::TechniqueSetup setup{context_,     *shaders,      casters_, scene, *slot.params,
                                           slot.light,   scene.bounds(), uint32_t(i), width_, height_};
        try {
            slot.instance = plugins_.create(*slot.plugin, setup, who);
            slot.technique = lc.shadow.technique;
        } catch (const plugin::PluginError& e) {
            if (slot.required) throw;
            dropTechnique(i, e.what());
        }
    }
}

void FrameRenderer::dropTechnique(size_t light, const std::string& why)
{
    LightSlot& slot = lights_[light];
    slot.instance.reset();
    slot.technique.clear();
    warnings_.push_back(fmt::format("light {}: rendered without shadows: {}", light, why));
}

// Declares the frame: engine resources and passes, every technique's passes, shading.
// A technique that throws while registering is dropped (unless required) and the graph
// is declared again without it, so that no half-registered pass stays behind.
void FrameRenderer::buildGraph()
{
    for (;;) {
        graph_ = std::make_unique<graph::RenderGraph>();
        graph::RenderGraph& g = *graph_;
        g.declareImage({kGPosition, width_, height_, kPositionFormat});
        g.declareImage({kGNormal, width_, height_, kNormalFormat});
        g.declareImage({kGAlbedo, width_, height_, kAlbedoFormat});
        g.declareImage({kGDepth, width_, height_, kDepthFormat});
        g.declareImage({kColor, width_, height_, kColorFormat});
        g.addPass("gbuffer", graph::QueueKind::Graphics)
            .write(kGPosition, graph::Usage::ColorAttachment)
            .write(kGNormal, graph::Usage::ColorAttachment)
            .write(kGAlbedo, graph::Usage::ColorAttachment)
            .write(kGDepth, graph::Usage::DepthAttachment)
            .execute([this](graph::PassContext& pass) { recordGBuffer(pass); });

        bool restart = false;
        for (size_t i = 0; i < lights_.size() && !restart; ++i) {
            g.declareImage({lights_[i].visibility, width_, height_, kVisibilityFormat});
            restart = !registerTechnique(i);
        }
        if (restart) continue;

        graph::PassBuilder shading = g.addPass("shading", graph::QueueKind::Compute);
        shading.read(kGPosition, graph::Usage::Storage)
            .read(kGNormal, graph::Usage::Storage)
            .read(kGAlbedo, graph::Usage::Storage)
            .write(kColor, graph::Usage::Storage)
            .execute([this](graph::PassContext& pass) { recordShading(pass); });
        for (const LightSlot& slot : lights_) shading.read(slot.visibility, graph::Usage::Sampled);
        // The colour image is the frame's result; V_l and the G-buffer surfaces are read
        // back by metrics and tests.
        g.markOutput(kColor);
        g.markOutput(kGPosition);
        g.markOutput(kGNormal);
        for (const LightSlot& slot : lights_) g.markOutput(slot.visibility);
        g.compile();
        return;
    }
}

// Registers light `light`'s technique passes, or the unshadowed fallback. Returns false
// when the technique failed and was dropped: the graph must be declared again.
bool FrameRenderer::registerTechnique(size_t light)
{
    LightSlot& slot = lights_[light];
    graph::RenderGraph& g = *graph_;
    if (slot.instance) {
        plugin::LightPassIo io;
        io.prefix = shadowPassPrefix(light);
        io.gPosition = kGPosition;
        io.gNormal = kGNormal;
        io.gDepth = kGDepth;
        io.visibility = slot.visibility;
        std::string failure;
        try {
            slot.instance->registerPasses(g, io);
            if (!g.isWritten(slot.visibility)) {
                failure = fmt::format("registered no pass that writes '{}' (the light's visibility image)",
                                      slot.visibility);
            }
        } catch (const std::exception& e) {
            failure = fmt::format("exception during registration: {}", e.what());
        }
        if (failure.empty()) return true;
        const std::string message = fmt::format("plugin '{}' (light {}): {}", slot.technique, light, failure);
        if (slot.required) throw plugin::PluginError(plugin::PluginErrorKind::RegistrationFailed, message);
        dropTechnique(light, message);
        return false;
    }
    // No technique: the light is unshadowed, V = 1 (the contract's neutral value).
    const std::string name = slot.visibility;
    g.addPass(shadowPassPrefix(light), graph::QueueKind::Graphics)
        .write(name, graph::Usage::TransferDst)
        .execute([name](graph::PassContext& pass) {
            const VkClearColorValue one{{1.0f, 1.0f, 1.0f, 1.0f}};
            VkImageSubresourceRange range{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
            vkCmdClearColorImage(pass.cmd(), pass.image(name).handle(), pass.layout(name), &one, 1, &range);
        });
    return true;
}

std::string FrameRenderer::shadowPassPrefix(size_t light) const
{
    const LightSlot& slot = lights_.at(light);
    return slot.instance ? fmt::format("light{}.{}.", light, slot.technique) : fmt::format("light{}.unshadowed", light);
}

const graph::CompiledGraph& FrameRenderer::compiledGraph() { return *graph_->compile(); }

void FrameRenderer::update(const config::RenderConfig& config, const scene::Scene& scene,
                           const std::vector<uint32_t>& movedInstances)
{
    if (config.lights.size() != lights_.size()) {
        throw Error(fmt::format("FrameRenderer::update: {} lights, the renderer was built for {}", config.lights.size(),
                                lights_.size()));
    }
    // Techniques hold the scene they were created with (TechniqueSetup::scene).
    if (&scene != &scene_) {
        throw Error("FrameRenderer::update: called with another scene than the renderer was built with; animate "
                    "that scene in place (config::applyAnimation, Scene::updateTransforms)");
    }
    cameraViewProj_ = render::cameraViewProj(config.camera, float(width_) / float(height_));
    if (!movedInstances.empty()) {
        sceneGpu_.updateInstances(context_, scene);
        visibility_->instancesMoved(movedInstances);
        for (LightSlot& slot : lights_)
            if (slot.instance) slot.instance->instancesMoved(movedInstances);
    }
    updateLights(config, scene.bounds());
}

void FrameRenderer::updateLights(const config::RenderConfig& config, const scene::Aabb& sceneBounds)
{
    currentLights_.resize(config.lights.size());
    for (size_t i = 0; i < config.lights.size(); ++i) {
        currentLights_[i] = config.lights[i].light;
        if (lights_[i].instance) lights_[i].instance->update(currentLights_[i], sceneBounds);
    }
    writeLightTable(currentLights_, static_cast<LightData*>(lightBuffer_.mapped()));
}

FrameTimings FrameRenderer::renderFrame()
{
    const auto frameStart = std::chrono::steady_clock::now();
    FrameTimings timings;
    // The previous frame has finished (execute() waits): its indirect commands are spent.
    sceneGpu_.beginFrame();
    // Step 1 of the visibility service: the camera's receivers (the G-buffer draws them);
    // light views are culled when their casters are first drawn.
    visibility_->beginFrame(cameraViewProj_);
    if (visibility_->focusing()) {
        // The techniques refit their maps to what the camera sees this frame.
        for (size_t i = 0; i < lights_.size(); ++i)
            if (lights_[i].instance) lights_[i].instance->update(currentLights_[i], scene_.bounds());
    }
    executor_.execute(*graph_);
    timings.passes = executor_.collectTimings();
    timings.culling = visibility_->stats();
    timings.frameCpuMs = msSince(frameStart);
    return timings;
}

void FrameRenderer::recordGBuffer(graph::PassContext& pass)
{
    const VkCommandBuffer cmd = pass.cmd();
    VkRenderingAttachmentInfo colors[3];
    const char* targets[3] = {kGPosition, kGNormal, kGAlbedo};
    for (int i = 0; i < 3; ++i) {
        colors[i] = {VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
        colors[i].imageView = pass.image(targets[i]).view();
        colors[i].imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
        colors[i].loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
        colors[i].storeOp = VK_ATTACHMENT_STORE_OP_STORE;
        colors[i].clearValue.color = {{0.0f, 0.0f, 0.0f, 0.0f}};  // w = 0: no geometry
    }
    VkRenderingAttachmentInfo depth{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
    depth.imageView = pass.image(kGDepth).view();
    depth.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
    depth.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
    // Kept: a technique (or the visibility service) may read the camera depth.
    depth.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
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
    sceneGpu_.draw(
        cmd, render::DrawFilter::All,
        [&](const gpu::Image& texture) {
            gpu::DescriptorPush()
                .storageBuffer("Instances", sceneGpu_.instanceBuffer())
                .storageBuffer("Materials", sceneGpu_.materialBuffer())
                .sampledImage("baseColorTexture", texture, sceneGpu_.textureSampler())
                .push(context_, cmd, gbufferPipeline_);
        },
        visibility_->receivers());
    vkCmdEndRendering(cmd);
}

void FrameRenderer::recordShading(graph::PassContext& pass)
{
    const VkCommandBuffer cmd = pass.cmd();
    std::vector<const gpu::Image*> visibility;
    for (const LightSlot& slot : lights_) visibility.push_back(&pass.image(slot.visibility));
    shadingPipeline_.bind(cmd);
    gpu::DescriptorPush()
        .storageImage("gPosition", pass.image(kGPosition))
        .storageImage("gNormal", pass.image(kGNormal))
        .storageImage("gAlbedo", pass.image(kGAlbedo))
        .sampledImages("visibility", visibility, nearestSampler_)
        .storageBuffer("Lights", lightBuffer_)
        .storageImage("outColor", pass.image(kColor))
        .push(context_, cmd, shadingPipeline_);
    const ShadingPush push{ambient_, background_};
    shadingPipeline_.pushConstants(cmd, &push, sizeof(push));
    shadingPipeline_.dispatchOver(cmd, width_, height_);
}

std::vector<uint8_t> FrameRenderer::readColor() const
{
    const std::vector<std::byte> bytes = gpu::readImage(context_, executor_.image(kColor), executor_.finalLayout(kColor));
    std::vector<uint8_t> out(bytes.size());
    std::memcpy(out.data(), bytes.data(), bytes.size());
    return out;
}

std::vector<float> FrameRenderer::readFloats(const std::string& name) const
{
    return gpu::readImageFloats(context_, executor_.image(name), executor_.finalLayout(name));
}

std::vector<float> FrameRenderer::readVisibility(size_t light) const { return readFloats(lights_.at(light).visibility); }

std::vector<float> FrameRenderer::readPositions() const { return readFloats(kGPosition); }

std::vector<float> FrameRenderer::readNormals() const { return readFloats(kGNormal); }

} // namespace penumbra::frame
