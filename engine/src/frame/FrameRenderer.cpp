#include "penumbra/frame/FrameRenderer.h"

#include "core/Clock.h"
#include "frame/FrameFormats.h"
#include "penumbra/core/Error.h"
#include "penumbra/gpu/Barrier.h"
#include "penumbra/gpu/GlslNames.h"
#include "frame/LightTable.h"
#include "penumbra/plugin/GBuffer.h"
#include "penumbra/plugin/Params.h"
#include "penumbra/plugin/VisibilityPass.h"
#include "visibility/Visibility.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>

namespace penumbra::frame {
namespace {

using plugin::kVisibilityFormat;

struct GBufferCameraData {  // matches GBufferCamera in shaders/common/gbuffer.glsl (std140)
    glm::vec4 eye;
    glm::vec4 rayX, rayY, rayZ;  // world point at NDC (x, y, depth): eye + (x rayX + y rayY + rayZ) / depth
    glm::vec4 size;
};

struct ShadingPush {
    glm::vec4 ambient;
    glm::vec4 background;
    glm::ivec4 region;  // the dispatch's first pixel and size
};

// Graph names of the engine's images (plugin::LightPassIo refers to the G-buffer ones).
constexpr const char* kGNormal = "gbuffer.normal";
constexpr const char* kGAlbedo = "gbuffer.albedo";
constexpr const char* kGDepth = "gbuffer.depth";
constexpr const char* kColor = "color";

} // namespace

FrameRenderer::FrameRenderer(std::shared_ptr<SceneResources> resources, const config::RenderConfig& config,
                             plugin::PluginRegistry& plugins, const FrameRenderer* previous)
    : resources_(std::move(resources)),
      context_(resources_->context()),
      plugins_(plugins),
      scene_(resources_->scene()),
      width_(config.width),
      height_(config.height),
      lightBuffer_(context_, sizeof(LightData) * config::kMaxLights, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true, "lights"),
      gbufferCamera_(context_, sizeof(GBufferCameraData), VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT, true, "gbuffer.camera"),
      castersFollowCamera_(config.culling != config::CullingMode::None || config.shadowFocus),
      changes_(scene_),
      keepUnchanged_(config.keepUnchanged),
      executor_(context_)
{
    if (config.lights.empty() || config.lights.size() > config::kMaxLights) {
        throw Error(fmt::format("{} lights: expected 1 to {}", config.lights.size(), config::kMaxLights));
    }
    if (resources_->batching() != SceneResources::batchingOf(config)) {
        throw Error("FrameRenderer: the scene's resources were made for another draw batching than the config's");
    }
    setCamera(config.camera);
    ambient_ = kSkyAmbient;
    background_ = kBackground;
    visibility_ = resources_->visibility(config.culling, width_, height_, config.shadowFocus);
    resources_->casters().setCulling(visibility_.get());

    createTechniques(config, previous);
    updateLights(config, scene_.bounds());
    noteChanges({});
    buildGraph();
}

FrameRenderer::FrameRenderer(gpu::Context& context, const scene::Scene& scene, const config::RenderConfig& config,
                             plugin::PluginRegistry& plugins)
    : FrameRenderer(std::make_shared<SceneResources>(context, scene, SceneResources::batchingOf(config)), config,
                    plugins)
{
}

// The shading pass is compiled for the frame's lights and the lights `shaded` (a bit per
// light) it adds: LIGHT_COUNT, and for each light i LIGHT_SHADED_<i> and
// LIGHT_VISIBILITY_<i> (engine/shading.glsl): 1.0 for a light without V this frame
// (unshadowed or culled), its element of the visibility[] array, or its technique's
// visibility function, composed in before shading's body under the prefix "light<i>_"
// with bindings of its own (kFunctionBindingBase on).
const gpu::Pipeline& FrameRenderer::shadingPipeline(uint32_t shaded)
{
    if (const auto found = shadingPipelines_.find(shaded); found != shadingPipelines_.end()) return *found->second;
    gpu::ComputePipelineDesc s;
    s.name = "shading";
    s.shader = "engine/shading.comp";
    s.defines = {{"LIGHT_COUNT", std::to_string(lights_.size())}};
    int slots = 0;
    std::string units, extensions;
    for (size_t i = 0; i < lights_.size(); ++i) {
        const LightSlot& slot = lights_[i];
        const bool adds = (shaded >> i) & 1u;
        std::string visibility = "1.0";
        if (adds && slot.hasImage()) {
            visibility = fmt::format("imageVisibility({})", slots++);
        } else if (adds && slot.inShading) {
            const std::string prefix = fmt::format("light{}_", i);
            const gpu::PrefixedUnit unit = gpu::prefixTopLevelNames(
                slot.inShading->function->preprocessedUnit(functionBindingBase(i)), prefix);
            for (const std::string& e : unit.extensions)
                if (extensions.find(e) == std::string::npos) extensions += e + "\n";
            units += fmt::format("// light {}: {}\n{}", i, slot.inShading->function->shader().string(), unit.text);
            visibility = fmt::format("fusedVisibility({}techniqueVisibility(pixel, position.xyz, n), position)", prefix);
        }
        s.defines.push_back({fmt::format("LIGHT_VISIBILITY_{}", i), visibility});
        s.defines.push_back({fmt::format("LIGHT_SHADED_{}", i), adds ? "1" : "0"});
    }
    s.defines.push_back({"VISIBILITY_COUNT", std::to_string(slots)});
    s.pushConstantBytes = sizeof(ShadingPush);
    if (!units.empty()) {
        // shading.comp's head (the functions' own), then the functions, then its body.
        s.source = plugin::visibilityFunctionHead(extensions) + units + "#include \"engine/shading.glsl\"\n";
    }
    const gpu::Pipeline& pipeline = resources_->computePipeline(s);
    shadingPipelines_.emplace(shaded, &pipeline);
    return pipeline;
}

// The rectangles shading covers this frame, each with the lights that can reach it
// (lightScreenRect): the screen cut along every light's rectangle, cells of one row with
// the same lights joined.
// Each light's rectangle is also where its technique's per-pixel passes run (LightPassIo::
// screenRegion).
void FrameRenderer::decideRegions()
{
    std::vector<ScreenRect>& rects = lightRects_;
    rects.assign(lights_.size(), ScreenRect{});
    std::vector<int32_t> xs = {0, int32_t(width_)}, ys = {0, int32_t(height_)};
    for (size_t i = 0; i < lights_.size(); ++i) {
        if (lights_[i].decision.fate == LightFate::Culled) continue;  // its row's radiance is 0
        rects[i] = lightRegions_ ? lightScreenRect(currentLights_[i], ambient_.w, receiversInView_, cameraPosition_,
                                                   cameraViewProj_, width_, height_)
                                 : ScreenRect{0, 0, int32_t(width_), int32_t(height_)};
        if (rects[i].empty()) continue;
        xs.insert(xs.end(), {rects[i].x0, rects[i].x1});
        ys.insert(ys.end(), {rects[i].y0, rects[i].y1});
    }
    std::sort(xs.begin(), xs.end());
    xs.erase(std::unique(xs.begin(), xs.end()), xs.end());
    std::sort(ys.begin(), ys.end());
    ys.erase(std::unique(ys.begin(), ys.end()), ys.end());
    std::vector<ShadingRegion> regions;
    for (size_t y = 0; y + 1 < ys.size(); ++y) {
        for (size_t x = 0; x + 1 < xs.size(); ++x) {
            const ScreenRect cell{xs[x], ys[y], xs[x + 1], ys[y + 1]};
            uint32_t shaded = 0;
            for (size_t i = 0; i < rects.size(); ++i)
                if (!rects[i].empty() && rects[i].contains(cell)) shaded |= 1u << i;
            if (!regions.empty() && regions.back().shaded == shaded && regions.back().rect.y0 == cell.y0 &&
                regions.back().rect.x1 == cell.x0) {
                regions.back().rect.x1 = cell.x1;
            } else {
                regions.push_back({cell, shaded});
            }
        }
    }
    shadingRegions_ = std::move(regions);
}

void FrameRenderer::setCamera(const scene::Camera& camera)
{
    const float aspect = float(width_) / float(height_);
    cameraViewProj_ = render::cameraViewProj(camera, aspect);
    cameraPosition_ = camera.position;
    // The unprojection, in double: world_h = M^-1 (x, y, depth, 1). For the infinite
    // reversed-Z perspective only the depth column has a w (1 / near), and it holds
    // eye / near, so world = eye + (x c0 + y c1 + c3) / (depth c2.w).
    const glm::dmat4 inverse =
        glm::inverse(glm::dmat4(render::perspectiveReversedZ(glm::radians(camera.fovYDeg), aspect, camera.nearWorld)) *
                     glm::dmat4(render::cameraView(camera)));
    const double wPerDepth = inverse[2][3];
    const double otherW = std::abs(inverse[0][3]) + std::abs(inverse[1][3]) + std::abs(inverse[3][3]);
    if (!(std::abs(wPerDepth) > 0.0) || !(otherW <= 1e-9 * std::abs(wPerDepth))) {
        throw Error(fmt::format("camera: near {} gives no reversed-Z perspective to unproject", camera.nearWorld));
    }
    auto* data = static_cast<GBufferCameraData*>(gbufferCamera_.mapped());
    data->eye = glm::vec4(camera.position, 1.0f);
    data->rayX = glm::vec4(glm::dvec3(inverse[0]) / wPerDepth, 0.0f);
    data->rayY = glm::vec4(glm::dvec3(inverse[1]) / wPerDepth, 0.0f);
    data->rayZ = glm::vec4(glm::dvec3(inverse[3]) / wPerDepth, 0.0f);
    data->size = glm::vec4(float(width_), float(height_), 0.0f, 0.0f);
}

FrameRenderer::~FrameRenderer()
{
    vkDeviceWaitIdle(context_.device());
    // Techniques are plugin code: destroy them (and the graph, whose callbacks they own)
    // while the registry still holds their libraries.
    graph_.reset();
    lights_.clear();
}

void FrameRenderer::createTechniques(const config::RenderConfig& config, const FrameRenderer* previous)
{
    lights_.resize(config.lights.size());
    for (size_t i = 0; i < config.lights.size(); ++i) {
        const config::LightConfig& lc = config.lights[i];
        LightSlot& slot = lights_[i];
        slot.visibility = fmt::format("light{}.visibility", i);
        slot.required = lc.shadow.registrationFailureStopsTheRun();
        slot.unshadowed = lc.shadow.unshadowed();
        if (slot.unshadowed) {
            slot.technique = lc.shadow.technique;
            continue;
        }
        const std::string who = fmt::format("light {} ('{}')", i, lc.name);
        const plugin::LoadedPlugin* loaded = nullptr;
        try {
            loaded = &plugins_.load(lc.shadow.technique);
        } catch (const plugin::PluginError& e) {
            if (lc.shadow.loadFailureStopsTheRun()) {
                const std::string where = lc.shadow.techniqueWhere.empty() ? "" : lc.shadow.techniqueWhere + ": ";
                throw plugin::PluginError(e.kind(), fmt::format("{}{}: {}{}", where, who, e.what(),
                                                                lc.shadow.required ? "" : config::kOptionalTechniqueHint));
            }
            dropTechnique(i, e.what());
            continue;
        }
        // Bad parameter values are the config's fault, not the plugin's: always an error.
        auto values = std::make_unique<plugin::ParamValues>(plugin::resolveParams(*loaded, lc.shadow));
        nlohmann::json params = values->toJson();
        if (auto kept = keptTechnique(previous, i, lc, *loaded, params)) {
            slot.created = std::move(kept);
            slot.instance = slot.created->instance.get();
            slot.technique = lc.shadow.technique;
            slot.kept = true;
            continue;
        }
        auto created = std::make_shared<CreatedTechnique>();
        created->plugin = loaded;
        created->name = lc.shadow.technique;
        created->params = std::move(params);
        created->values = std::move(values);
        created->light = lc.light;
        const plugin::TechniqueSetup setup{context_,
                                           resources_->pluginShaders(loaded->shaderDir),
                                           resources_->casters(),
                                           scene_,
                                           *created->values,
                                           created->light,
                                           scene_.bounds(),
                                           uint32_t(i),
                                           width_,
                                           height_,
                                           fmt::format("light{}.{}.", i, lc.shadow.technique)};
        try {
            created->instance = plugins_.create(*loaded, setup, who);
            slot.created = std::move(created);
            slot.instance = slot.created->instance.get();
            slot.technique = lc.shadow.technique;
        } catch (const plugin::PluginError& e) {
            if (slot.required) throw;
            dropTechnique(i, e.what());
        }
    }
}

// What a technique is created from besides the light's pose and radiance (which update()
// passes it every frame): the plugin, its parameters, the light's type and shape, the
// light's index and the output, and the scene's resources and culling it draws with.
std::shared_ptr<FrameRenderer::CreatedTechnique> FrameRenderer::keptTechnique(const FrameRenderer* previous,
                                                                              size_t light,
                                                                              const config::LightConfig& config,
                                                                              const plugin::LoadedPlugin& plugin,
                                                                              const nlohmann::json& params) const
{
    if (!previous || previous->resources_ != resources_ || previous->visibility_ != visibility_ ||
        previous->width_ != width_ || previous->height_ != height_ || light >= previous->lights_.size()) {
        return nullptr;
    }
    const std::shared_ptr<CreatedTechnique>& created = previous->lights_[light].created;
    if (!created || !created->instance || created->plugin != &plugin || created->name != config.shadow.technique ||
        created->params != params) {
        return nullptr;
    }
    const scene::Light& a = created->light;
    const scene::Light& b = config.light;
    const bool sameShape = a.type == b.type && a.outerConeDeg == b.outerConeDeg && a.innerConeDeg == b.innerConeDeg &&
                           a.angularDiameterDeg == b.angularDiameterDeg && a.sizeWorld == b.sizeWorld &&
                           a.radiusWorld == b.radiusWorld;
    return sameShape ? created : nullptr;
}

void FrameRenderer::dropTechnique(size_t light, const std::string& why)
{
    LightSlot& slot = lights_[light];
    slot.created.reset();
    slot.instance = nullptr;
    slot.kept = false;
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
        g.setKeepUnchanged(keepUnchanged_);
        g.declareImage({kGNormal, width_, height_, kGBufferNormalFormat});
        g.declareImage({kGAlbedo, width_, height_, kGBufferAlbedoFormat});
        g.declareImage({kGDepth, width_, height_, kFrameDepthFormat});
        g.declareImage({kColor, width_, height_, kFrameColorFormat});
        g.addPass("gbuffer", graph::QueueKind::Graphics)
            .write(kGNormal, graph::Usage::ColorAttachment)
            .write(kGAlbedo, graph::Usage::ColorAttachment)
            .write(kGDepth, graph::Usage::DepthAttachment)
            .dependsOn(render::kCameraState)
            .execute([this](graph::PassContext& pass) { recordGBuffer(pass); });

        bool restart = false;
        for (LightSlot& slot : lights_) slot.inShading.reset();
        for (size_t i = 0; i < lights_.size() && !restart; ++i) {
            if (!lights_[i].drawn()) continue;
            restart = !registerTechnique(i);
            if (!restart && lights_[i].hasImage())
                g.declareImage({lights_[i].visibility, width_, height_, kVisibilityFormat});
        }
        if (restart) {
            decideLights();  // the dropped light is lit unshadowed; another may take its shadows
            continue;
        }
        // Made as the frames need them: settings made after the graph is declared
        // (setVisibilityReadBack) compile no shading that no frame uses.
        shadingPipelines_.clear();

        graph::PassBuilder shading = g.addPass("shading", graph::QueueKind::Compute);
        shading.read(kGDepth, graph::Usage::Sampled)
            .read(kGNormal, graph::Usage::Sampled)
            .read(kGAlbedo, graph::Usage::Sampled)
            .write(kColor, graph::Usage::Storage)
            .dependsOn(render::kCameraState)
            .dependsOn(kLightTableState)
            .execute([this](graph::PassContext& pass) { recordShading(pass); });
        for (const LightSlot& slot : lights_) {
            if (slot.hasImage()) shading.read(slot.visibility, graph::Usage::Sampled);
            if (slot.inShading)
                for (const std::string& read : slot.inShading->sampledReads) shading.read(read, graph::Usage::Sampled);
        }
        // The colour image is the frame's result; V_l and the G-buffer surfaces (depth and
        // normal: readPositions, readNormals) are read back by metrics and tests.
        g.markOutput(kColor);
        g.markOutput(kGDepth);
        g.markOutput(kGNormal);
        for (const LightSlot& slot : lights_)
            if (slot.hasImage()) g.markOutput(slot.visibility);
        for (const std::string& name : requestedImages_) g.markOutput(name);
        g.compile();
        return;
    }
}

// Registers light `light`'s technique passes. Returns false when the technique failed and
// was dropped: the graph must be declared again.
bool FrameRenderer::registerTechnique(size_t light)
{
    LightSlot& slot = lights_[light];
    graph::RenderGraph& g = *graph_;
    plugin::LightPassIo io;
    io.prefix = shadowPassPrefix(light);
    io.gbuffer = gbufferIo();
    io.visibility = slot.visibility;
    io.lightState = render::lightState(uint32_t(light));
    io.cameraState = render::kCameraState;
    io.bindImage = [this](std::string_view name, const gpu::Image& image) { executor_.bindImage(name, image); };
    io.bindBuffer = [this](std::string_view name, const gpu::Buffer& buffer) { executor_.bindBuffer(name, buffer); };
    io.screenRegion = [this, light] {
        // Not decided yet (no frame's lights): the whole screen, as without regions.
        if (light >= lightRects_.size()) return VkRect2D{{0, 0}, {width_, height_}};
        const ScreenRect r = lightRects_[light];
        return r.empty() ? VkRect2D{} : VkRect2D{{r.x0, r.y0}, {uint32_t(r.x1 - r.x0), uint32_t(r.y1 - r.y0)}};
    };
    visibilityFillPipeline();  // made with the graph, not as a frame records
    io.fillOutside = [this](VkCommandBuffer cmd, const gpu::Image& image, VkRect2D inside) {
        fillVisibility(cmd, image, inside);
    };
    if (!visibilityReadBack_) {
        io.evaluateInShading = [this, light](const plugin::VisibilityInShading& function) {
            if (!shadingTakesFunction(*function.function)) return false;
            lights_[light].inShading = function;
            return true;
        };
    }
    std::string failure;
    try {
        slot.created->declaredBy = this;
        slot.instance->registerPasses(g, io);
        if (slot.inShading && g.isWritten(slot.visibility)) {
            failure = fmt::format("wrote '{}' although shading evaluates the light's visibility function",
                                  slot.visibility);
        } else if (!slot.inShading && !g.isWritten(slot.visibility)) {
            failure = fmt::format("registered no pass that writes '{}' (the light's visibility image)",
                                  slot.visibility);
        }
    } catch (const std::exception& e) {
        failure = fmt::format("exception during registration: {}", e.what());
    }
    if (failure.empty()) return true;
    slot.inShading.reset();
    const std::string message = fmt::format("plugin '{}' (light {}): {}", slot.technique, light, failure);
    if (slot.required) throw plugin::PluginError(plugin::PluginErrorKind::RegistrationFailed, message);
    dropTechnique(light, message);
    return false;
}

// Shading's push descriptors: its own six, one per visibility image, and each function's
// own, within the 32 that every Vulkan device with push descriptors offers
// (maxPushDescriptors). Counted as if every light not yet registered had an image.
bool FrameRenderer::shadingTakesFunction(const plugin::VisibilityFunction& function) const
{
    constexpr uint32_t kShadingOwn = 6, kMinMaxPushDescriptors = 32;
    uint32_t images = 0, descriptors = kShadingOwn + function.descriptorCount();
    for (const LightSlot& slot : lights_) {
        if (slot.inShading) descriptors += slot.inShading->function->descriptorCount();
        else if (slot.drawn()) ++images;
    }
    return descriptors + images - 1 <= kMinMaxPushDescriptors;  // the asking light has no image
}

uint32_t FrameRenderer::functionBindingBase(size_t light)
{
    return kFunctionBindingBase + uint32_t(light) * plugin::kMaxVisibilityFunctionBindings;
}

const gpu::Pipeline& FrameRenderer::visibilityFillPipeline()
{
    gpu::ComputePipelineDesc desc;
    desc.name = "visibility_fill";
    desc.shader = "engine/visibility_fill.comp";
    desc.pushConstantBytes = sizeof(glm::ivec4);
    return resources_->computePipeline(desc);
}

void FrameRenderer::fillVisibility(VkCommandBuffer cmd, const gpu::Image& image, VkRect2D inside)
{
    const gpu::Pipeline& fill = visibilityFillPipeline();
    fill.bind(cmd);
    gpu::DescriptorPush().storageImage("visibilityOut", image).push(context_, cmd, fill);
    const glm::ivec4 rect{inside.offset.x, inside.offset.y, inside.offset.x + int32_t(inside.extent.width),
                          inside.offset.y + int32_t(inside.extent.height)};
    fill.pushConstants(cmd, &rect, sizeof(rect));
    fill.dispatchOver(cmd, image);
}

void FrameRenderer::setLightRegions(bool regions)
{
    lightRegions_ = regions;
    decideRegions();
}

void FrameRenderer::setVisibilityReadBack(bool readBack)
{
    if (readBack == visibilityReadBack_) return;
    visibilityReadBack_ = readBack;
    buildGraph();
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
    setCamera(config.camera);
    if (!movedInstances.empty()) {
        resources_->instancesMoved(movedInstances);
        for (LightSlot& slot : lights_)
            if (slot.instance) slot.instance->instancesMoved(movedInstances);
    }
    const std::vector<LightFate> before = fates();
    updateLights(config, scene.bounds());
    noteChanges(movedInstances);
    // A light that left or entered the view, or changed rank: other passes, another shading.
    if (fates() != before) buildGraph();
}

std::vector<LightFate> FrameRenderer::fates() const
{
    std::vector<LightFate> out;
    for (const LightSlot& slot : lights_) out.push_back(slot.decision.fate);
    return out;
}

void FrameRenderer::updateLights(const config::RenderConfig& config, const scene::Aabb& sceneBounds)
{
    lightCulling_ = config.lightCulling;
    maxShadowedLights_ = config.maxShadowedLights;
    currentLights_.resize(config.lights.size());
    for (size_t i = 0; i < config.lights.size(); ++i) {
        currentLights_[i] = config.lights[i].light;
        if (lights_[i].instance) lights_[i].instance->update(currentLights_[i], sceneBounds);
    }
    decideLights();
}

// Which lights can matter to this frame (LightInfluence.h), from the camera, the lights
// and the instances in view; a culled light's row gets no radiance, so that shading adds
// exactly nothing for it.
void FrameRenderer::decideLights()
{
    LightCullingInput input;
    input.cameraViewProj = cameraViewProj_;
    input.cameraPosition = cameraPosition_;
    input.exposure = ambient_.w;
    input.lights = currentLights_;
    for (const LightSlot& slot : lights_) input.shadowed.push_back(!slot.unshadowed && slot.instance);
    receiversInView_ = resources_->instanceBoxesInView(cameraViewProj_);
    input.visibleBoxes = receiversInView_;
    input.cullLights = lightCulling_;
    input.maxShadowedLights = maxShadowedLights_;
    std::vector<LightDecision> decided = frame::decideLights(input);
    auto* rows = static_cast<LightData*>(lightBuffer_.mapped());
    writeLightTable(currentLights_, rows);
    for (size_t i = 0; i < lights_.size(); ++i) {
        lights_[i].decision = std::move(decided[i]);
        if (lights_[i].decision.fate == LightFate::Culled) rows[i].radiance = glm::vec4(glm::vec3(0.0f), rows[i].radiance.w);
    }
    // Where shading adds each light follows from the same camera, lights and receivers:
    // decided with them, not every frame.
    decideRegions();
}

// The versions of the states that passes depend on (FrameChanges.h), for the executor to
// keep what did not change.
void FrameRenderer::noteChanges(std::span<const uint32_t> movedInstances)
{
    FrameInputs inputs;
    inputs.cameraViewProj = cameraViewProj_;
    inputs.lights = currentLights_;
    inputs.sceneBounds = scene_.bounds();
    inputs.movedInstances = movedInstances;
    inputs.castersFollowCamera = castersFollowCamera_;
    inputs.lightTable = {static_cast<const std::byte*>(lightBuffer_.mapped()), sizeof(LightData) * config::kMaxLights};
    changes_.update(inputs, scene_);
}

void FrameRenderer::execute()
{
    for (const ShadingRegion& region : shadingRegions_) shadingPipeline(region.shaded);
    graph_->setState(render::kCameraState, changes_.camera());
    graph_->setState(kLightTableState, changes_.lightTable());
    for (size_t i = 0; i < lights_.size(); ++i) graph_->setState(render::lightState(uint32_t(i)), changes_.light(i));
    executor_.execute(*graph_);
    changes_.viewsDrawn(resources_->casters().takeDrawnViews());
}

FrameTimings FrameRenderer::renderFrame()
{
    const auto frameStart = std::chrono::steady_clock::now();
    FrameTimings timings;
    // Techniques this renderer shares with another renderer over the same scene (an edit
    // that failed, say) hold the other's graph now: declare ours again, with our lights.
    resources_->casters().setCulling(visibility_.get());
    bool declaredElsewhere = false;
    for (size_t i = 0; i < lights_.size(); ++i) {
        if (!lights_[i].drawn() || lights_[i].created->declaredBy == this) continue;
        lights_[i].instance->update(currentLights_[i], scene_.bounds());
        declaredElsewhere = true;
    }
    if (declaredElsewhere) buildGraph();
    // The previous frame has finished (execute() waits): its indirect commands are spent.
    resources_->sceneGpu().beginFrame();
    // Step 1 of the visibility service: the camera's receivers (the G-buffer draws them);
    // light views are culled when their casters are first drawn.
    visibility_->beginFrame(cameraViewProj_);
    if (visibility_->focusing()) {
        // The techniques refit their maps to what the camera sees this frame.
        for (size_t i = 0; i < lights_.size(); ++i)
            if (lights_[i].drawn()) lights_[i].instance->update(currentLights_[i], scene_.bounds());
    }
    execute();
    for (uint32_t redraw = 0; redraw < kMaxRedraws; ++redraw) {
        bool grew = false;
        for (LightSlot& slot : lights_)
            if (slot.drawn() && slot.instance->wantsRedraw()) grew = true;
        if (!grew) break;
        buildGraph();
        resources_->sceneGpu().beginFrame();
        visibility_->beginFrame(cameraViewProj_);
        execute();
        ++timings.redraws;
    }
    timings.passes = executor_.collectTimings();
    timings.culling = visibility_->stats();
    timings.techniques.resize(lights_.size());
    for (size_t i = 0; i < lights_.size(); ++i) {
        if (lights_[i].drawn()) timings.techniques[i] = lights_[i].instance->figures();
        timings.lights.push_back(lights_[i].decision);
    }
    timings.frameCpuMs = core::msSince(frameStart);
    return timings;
}

void FrameRenderer::recordGBuffer(graph::PassContext& pass)
{
    const VkCommandBuffer cmd = pass.cmd();
    render::SceneGpu& sceneGpu = resources_->sceneGpu();
    BaseColorPipelines& gbufferPipelines = resources_->gbufferPipelines();
    VkRenderingAttachmentInfo colors[2];
    const char* targets[2] = {kGNormal, kGAlbedo};
    for (int i = 0; i < 2; ++i) {
        colors[i] = {VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
        colors[i].imageView = pass.image(targets[i]).view();
        colors[i].imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
        colors[i].loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
        colors[i].storeOp = VK_ATTACHMENT_STORE_OP_STORE;
        colors[i].clearValue.color = {{0.0f, 0.0f, 0.0f, 0.0f}};  // where no geometry: depth 0 says so
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
    info.colorAttachmentCount = 2;
    info.pColorAttachments = colors;
    info.pDepthAttachment = &depth;
    vkCmdBeginRendering(cmd, &info);
    VkViewport viewport{0.0f, 0.0f, float(width_), float(height_), 0.0f, 1.0f};
    VkRect2D scissor{{0, 0}, {width_, height_}};
    vkCmdSetViewport(cmd, 0, 1, &viewport);
    vkCmdSetScissor(cmd, 0, 1, &scissor);
    gbufferPipelines.begin();
    sceneGpu.draw(
        cmd, render::DrawFilter::All,
        [&](const gpu::Image& texture) {
            const gpu::Pipeline& pipeline =
                gbufferPipelines.bindFor(cmd, sceneGpu, texture, &cameraViewProj_, sizeof(glm::mat4));
            gpu::DescriptorPush descriptors;
            descriptors.storageBuffer("Instances", sceneGpu.instanceBuffer())
                .storageBuffer("Materials", sceneGpu.materialBuffer());
            if (gbufferPipelines.textured(pipeline))
                descriptors.sampledImage("baseColorTexture", texture, sceneGpu.textureSampler());
            descriptors.push(context_, cmd, pipeline);
        },
        visibility_->receivers());
    vkCmdEndRendering(cmd);
}

void FrameRenderer::recordShading(graph::PassContext& pass)
{
    const VkCommandBuffer cmd = pass.cmd();
    for (const ShadingRegion& region : shadingRegions_) {
        const gpu::Pipeline& shading = shadingPipeline(region.shaded);
        shading.bind(cmd);
        gpu::DescriptorPush descriptors;
        plugin::bindGBuffer(pass, gbufferIo(), descriptors);
        descriptors.sampledImage("gAlbedo", pass.image(kGAlbedo), resources_->nearestSampler(), pass.layout(kGAlbedo))
            .storageBuffer("Lights", lightBuffer_)
            .storageImage("outColor", pass.image(kColor));
        std::vector<const gpu::Image*> visibility;
        for (size_t i = 0; i < lights_.size(); ++i) {
            if (!((region.shaded >> i) & 1u)) continue;
            if (lights_[i].hasImage()) visibility.push_back(&pass.image(lights_[i].visibility));
            if (!lights_[i].inShading) continue;
            descriptors.setNamePrefix(fmt::format("light{}_", i));  // the function's names in shading
            lights_[i].inShading->bind(pass, descriptors);
            descriptors.setNamePrefix({});
        }
        if (!visibility.empty()) descriptors.sampledImages("visibility", visibility, resources_->nearestSampler());
        descriptors.push(context_, cmd, shading);
        const ScreenRect& r = region.rect;
        const ShadingPush push{ambient_, background_, glm::ivec4(r.x0, r.y0, r.x1 - r.x0, r.y1 - r.y0)};
        shading.pushConstants(cmd, &push, sizeof(push));
        shading.dispatchOver(cmd, uint32_t(r.x1 - r.x0), uint32_t(r.y1 - r.y0));
    }
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

std::vector<std::string> FrameRenderer::imageNames() const { return graph_->writtenImages(); }

void FrameRenderer::requestImage(const std::string& name)
{
    const std::vector<std::string> names = imageNames();
    if (std::find(names.begin(), names.end(), name) == names.end()) {
        std::string list;
        for (const std::string& n : names) list += (list.empty() ? "" : ", ") + n;
        throw ConfigError(fmt::format("debug image '{}': the frame has no such image; its images: {}", name, list));
    }
    // An output is kept with its writers, and stays readable after the frame.
    graph_->markOutput(name);
    if (std::find(requestedImages_.begin(), requestedImages_.end(), name) == requestedImages_.end())
        requestedImages_.push_back(name);
}

metrics::DebugImageValues FrameRenderer::readImage(const std::string& name) const
{
    const gpu::Image& image = executor_.image(name);
    metrics::DebugImageValues values;
    values.width = image.desc().width;
    values.height = image.desc().height;
    values.channels = gpu::channelCount(image.desc().format);
    values.values = readFloats(name);
    return values;
}

std::string FrameRenderer::noVisibilityImage(size_t light) const
{
    return fmt::format("light {}: shading evaluates its visibility ({}'s visibility function), so it has no image "
                       "to read; setVisibilityReadBack(true) keeps one",
                       light, lights_.at(light).technique);
}

std::vector<float> FrameRenderer::readVisibility(size_t light) const
{
    const LightSlot& slot = lights_.at(light);
    if (!slot.drawn()) return std::vector<float>(size_t(width_) * height_, 1.0f);
    if (slot.inShading) throw Error(noVisibilityImage(light));
    return readFloats(slot.visibility);
}

FrameRenderer::Pixel FrameRenderer::readPixel(uint32_t x, uint32_t y) const
{
    if (x >= width_ || y >= height_) {
        throw Error(fmt::format("readPixel: ({}, {}) is outside the {} x {} frame", x, y, width_, height_));
    }
    const VkRect2D texel{{int32_t(x), int32_t(y)}, {1, 1}};
    Pixel pixel;
    const std::vector<std::byte> color =
        gpu::readImage(context_, executor_.image(kColor), executor_.finalLayout(kColor), texel);
    std::memcpy(pixel.color.data(), color.data(), pixel.color.size());
    for (size_t i = 0; i < lights_.size(); ++i) {
        const LightSlot& slot = lights_[i];
        if (slot.inShading) throw Error(noVisibilityImage(i));
        pixel.visibility.push_back(!slot.drawn() ? 1.0f
                                                   : gpu::readImageFloats(context_, executor_.image(slot.visibility),
                                                                          executor_.finalLayout(slot.visibility), texel)
                                                         .at(0));
    }
    return pixel;
}

plugin::GBufferIo FrameRenderer::gbufferIo() const
{
    plugin::GBufferIo io;
    io.depth = kGDepth;
    io.normal = kGNormal;
    io.camera = &gbufferCamera_;
    io.sampler = resources_->nearestSampler();
    return io;
}

// The G-buffer's positions and normals as the techniques' shaders read them: exported on
// the GPU by plugin::GBufferExport (common/gbuffer.glsl's readers), not decoded again here.
FrameRenderer::SurfaceFloats FrameRenderer::readSurfaces() const
{
    const plugin::GBufferExport& gbufferExport = resources_->gbufferExport();
    const VkDeviceSize bytes = VkDeviceSize(width_) * height_ * plugin::GBufferExport::kTexelBytes;
    const gpu::Buffer positions(context_, bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true, "gbuffer.positions_readback");
    const gpu::Buffer normals(context_, bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true, "gbuffer.normals_readback");
    const gpu::Image& depth = executor_.image(kGDepth);
    const gpu::Image& normal = executor_.image(kGNormal);
    const VkImageLayout depthLayout = executor_.finalLayout(kGDepth), normalLayout = executor_.finalLayout(kGNormal);
    const gpu::ImageAccess depthRead = gpu::access::kComputeSampledDepth, normalRead = gpu::access::kComputeSampled;
    context_.submitAndWait([&](VkCommandBuffer cmd) {
        const gpu::ImageAccess last{VK_IMAGE_LAYOUT_UNDEFINED, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                                    VK_ACCESS_2_MEMORY_WRITE_BIT};
        gpu::transition(cmd, depth, {depthLayout, last.stage, last.access}, depthRead);
        gpu::transition(cmd, normal, {normalLayout, last.stage, last.access}, normalRead);
        gbufferExport.record(cmd, depth, depthRead.layout, normal, normalRead.layout, gbufferCamera_,
                             resources_->nearestSampler(), positions, normals);
        gpu::memoryBarrier(cmd, {VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT},
                           {VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT});
        gpu::transition(cmd, depth, depthRead, {depthLayout, last.stage, VK_ACCESS_2_MEMORY_READ_BIT});
        gpu::transition(cmd, normal, normalRead, {normalLayout, last.stage, VK_ACCESS_2_MEMORY_READ_BIT});
    });
    const size_t floats = size_t(bytes / sizeof(float));
    SurfaceFloats out;
    out.positions.resize(floats);
    out.normals.resize(floats);
    std::memcpy(out.positions.data(), positions.mapped(), bytes);
    std::memcpy(out.normals.data(), normals.mapped(), bytes);
    return out;
}

std::vector<float> FrameRenderer::readPositions() const { return readSurfaces().positions; }

std::vector<float> FrameRenderer::readNormals() const { return readSurfaces().normals; }

} // namespace penumbra::frame
