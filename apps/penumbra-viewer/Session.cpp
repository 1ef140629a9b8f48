#include "Session.h"

#include "penumbra/core/Error.h"
#include "penumbra/gpu/ShaderCompiler.h"
#include "penumbra/plugin/Params.h"
#include "penumbra/scene/GltfLoader.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>

namespace fs = std::filesystem;

namespace penumbra::viewer {
namespace {

bool isGltf(const fs::path& file)
{
    std::string ext = file.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    return ext == ".gltf" || ext == ".glb";
}

} // namespace

config::RenderConfig configForGltf(const fs::path& file, const scene::Scene& scene,
                                   const std::vector<scene::GltfLight>& fileLights)
{
    config::RenderConfig c;
    c.file = file;
    c.scene.parts[0].kind = config::ScenePart::Kind::Gltf;
    c.scene.parts[0].gltf = fs::absolute(file);
    const scene::Aabb bounds = scene.bounds();
    // A scene of one point (or none) still gets a camera: a unit radius around it.
    const float radius = bounds.radius() > 0.0f && std::isfinite(bounds.radius()) ? bounds.radius() : 1.0f;
    const glm::vec3 center = bounds.empty() ? glm::vec3(0.0f) : bounds.center();
    c.camera.target = center;
    c.camera.position = center + glm::normalize(glm::vec3(1.0f, 0.7f, 1.3f)) * (radius * 2.4f);
    c.camera.fovYDeg = 45.0f;
    // The depth buffer's precision is relative: a near plane at 1e-3 of the scene's size.
    c.camera.nearWorld = radius * 1e-3f;
    // The file's first animation plays (the viewer's timeline; Save writes which one, and
    // frames enough for `penumbra render` to play it through).
    if (!scene.animations.empty()) {
        c.scene.parts[0].animation = scene.animations.front().name;
        c.frames = config::framesToPlay(scene.animations.front().duration(), c.animation.fps);
    }
    if (!fileLights.empty()) {
        c.lightsFromScene = true;
        for (size_t i = 0; i < fileLights.size() && i < config::kMaxLights; ++i) {
            config::LightConfig lc;
            lc.name = fileLights[i].name.empty() ? fmt::format("light{}", i) : fileLights[i].name;
            lc.light = fileLights[i].light;
            c.lights.push_back(lc);
        }
    } else {
        config::LightConfig sun;
        sun.name = "sun";
        sun.light.type = scene::LightType::Directional;
        sun.light.direction = glm::normalize(glm::vec3(-0.45f, -1.0f, -0.3f));
        sun.light.angularDiameterDeg = 0.53f;
        sun.light.intensity = 3.0f;
        c.lights.push_back(sun);
    }
    return c;
}

Session::Session(gpu::Context& context, plugin::PluginRegistry& plugins) : context_(context), plugins_(&plugins) {}

Session::~Session() = default;

void Session::open(const fs::path& file)
{
    auto run = std::make_unique<config::PreparedRun>();
    config::RenderConfig c;
    if (isGltf(file)) {
        config::SceneSource source;
        source.parts[0].kind = config::ScenePart::Kind::Gltf;
        source.parts[0].gltf = file;
        std::vector<scene::GltfLight> lights;
        run->scene = config::buildScene(source, &lights);
        c = configForGltf(file, run->scene, lights);
    } else {
        c = config::loadConfig(file);
        run->scene = config::buildScene(c);  // with "lights": "scene", fills the lights
    }
    run->rest = c;
    run->config = c;
    // The new scene's renderer first: a failure leaves what was shown.
    auto resources = std::make_shared<frame::SceneResources>(context_, run->scene, frame::SceneResources::batchingOf(c));
    auto renderer = std::make_unique<frame::FrameRenderer>(resources, c, *plugins_);
    renderer_.reset();  // it refers to the old scene
    renderer_ = std::move(renderer);
    resources_ = std::move(resources);
    run_ = std::move(run);
    file_ = file;
    config_ = c;
    shown_ = c;
    shownImage_.clear();
    paramsByTechnique_.assign(c.lights.size(), {});
    time_ = 0.0f;
    follow_ = CameraFollow::Track;
    drawnCamera_ = c.camera;
    for (const std::string& warning : renderer_->warnings()) spdlog::warn("{}", warning);
    pending_ = Change::View;  // the new renderer has not drawn yet
    framesRendered_ = 0;
    lastError_.clear();
}

void Session::changed(Change change) { pending_ = std::max(pending_, change); }

config::RenderConfig Session::shownView() const
{
    return follow_ == CameraFollow::Free ? withoutCameraTracks(shown_) : shown_;
}

void Session::setCameraFollow(CameraFollow follow)
{
    if (follow == CameraFollow::Free && followsCameraTrack()) config_.camera = drawnCamera_;
    follow_ = follow;
    changed(Change::View);
}

bool Session::moveCamera(const scene::Camera& camera)
{
    const bool followed = followsCameraTrack();
    follow_ = CameraFollow::Free;
    config_.camera = camera;
    changed(Change::View);
    return followed;
}

void Session::setParam(size_t light, const std::string& name, const nlohmann::json& value, const std::string& where)
{
    config::ShadowSettings& shadow = config_.lights.at(light).shadow;
    if (shadow.unshadowed()) throw ConfigError(fmt::format("{}: light {} is unshadowed (technique \"none\")", where, light));
    config::ShadowSettings trial = shadow;
    trial.setParam(name, value, where);
    plugin::resolveParams(plugins_->load(trial.technique), trial);  // throws naming `where`
    shadow = std::move(trial);
    changed(Change::Renderer);
}

void Session::setTechnique(size_t light, const std::string& technique)
{
    config::ShadowSettings& shadow = config_.lights.at(light).shadow;
    if (shadow.technique == technique) return;
    if (technique != config::kNoShadowTechnique) plugins_->load(technique);  // throws PluginError naming it
    paramsByTechnique_.resize(config_.lights.size());
    auto& saved = paramsByTechnique_[light];
    saved[shadow.technique] = shadow.params;
    shadow.technique = technique;
    shadow.params = saved.count(technique) ? saved[technique] : std::vector<config::ShadowParam>{};
    changed(Change::Renderer);
}

void Session::addLight(config::LightConfig light)
{
    if (config_.lights.size() >= config::kMaxLights) {
        throw ConfigError(fmt::format("a frame shades at most {} lights", config::kMaxLights));
    }
    std::string name = light.name;
    auto taken = [&](const std::string& n) {
        return std::any_of(config_.lights.begin(), config_.lights.end(), [&](const auto& l) { return l.name == n; });
    };
    for (size_t i = config_.lights.size(); name.empty() || taken(name); ++i) name = fmt::format("light{}", i);
    light.name = name;
    config_.lights.push_back(std::move(light));
    paramsByTechnique_.resize(config_.lights.size());
    changed(Change::Renderer);
}

void Session::removeLight(size_t light)
{
    if (config_.lights.size() <= 1) throw ConfigError("the last light cannot be removed: a config has at least one");
    config_.lights.erase(config_.lights.begin() + long(light));
    if (light < paramsByTechnique_.size()) paramsByTechnique_.erase(paramsByTechnique_.begin() + long(light));
    // "/lights/<i>/..." tracks: the removed light's go, later lights' move down by one.
    std::vector<config::AnimationTrack> kept;
    for (config::AnimationTrack& track : config_.animation.tracks) {
        if (track.target.rfind("/lights/", 0) == 0) {
            const size_t end = track.target.find('/', 8);
            const size_t index = std::stoul(track.target.substr(8, end - 8));
            if (index == light) continue;
            if (index > light) track.target = fmt::format("/lights/{}{}", index - 1, track.target.substr(end));
        }
        kept.push_back(std::move(track));
    }
    config_.animation.tracks = std::move(kept);
    changed(Change::Renderer);
}

std::optional<plugin::ParamValues> Session::params(size_t light)
{
    const config::ShadowSettings& shadow = config_.lights.at(light).shadow;
    if (shadow.unshadowed()) return std::nullopt;
    try {
        return plugin::resolveParams(plugins_->load(shadow.technique), shadow);
    } catch (const Error& e) {
        lastError_ = e.what();
        return std::nullopt;
    }
}

void Session::showImage(const std::string& name)
{
    if (name == shownImage_) return;
    if (!name.empty()) {
        const std::vector<std::string> names = renderer_->imageNames();
        if (std::find(names.begin(), names.end(), name) == names.end()) {
            renderer_->requestImage(name);  // throws ConfigError listing the frame's images
        }
    }
    shownImage_ = name;
    changed(Change::Renderer);  // a request keeps passes alive; a renderer without it drops them again
}

std::vector<std::string> Session::techniqueNames()
{
    if (!techniques_) {
        std::vector<std::string> names;
        // Scanned, not loaded: only the techniques a light uses run in the viewer's process.
        for (const plugin::PluginMetadata* p : plugins_->scanAll().plugins) names.push_back(p->name());
        std::sort(names.begin(), names.end());
        names.insert(names.begin(), std::string(config::kNoShadowTechnique));
        techniques_ = names;
    }
    return *techniques_;
}

void Session::usePlugins(plugin::PluginRegistry& plugins)
{
    newPlugins_ = &plugins;
    changed(Change::Renderer);
}

const config::RenderConfig& Session::pose(std::vector<uint32_t>& moved) const
{
    moved.clear();
    // The edited config is the rest pose: the animation starts from it, as in `penumbra render`.
    run_->rest = follow_ == CameraFollow::Free ? withoutCameraTracks(config_) : config_;
    if (config::animated(run_->rest)) {
        moved = run_->poseAt(time_);
    } else {
        run_->config = run_->rest;
    }
    return run_->config;
}

float Session::duration() const { return config::animationDuration(config_, run_->scene); }

void Session::setTime(float seconds)
{
    const float t = std::clamp(std::isfinite(seconds) ? seconds : 0.0f, 0.0f, duration());
    if (t == time_) return;
    time_ = t;
    changed(Change::View);
}

std::unique_ptr<frame::FrameRenderer> Session::build()
{
    // A technique that drew, or that the user just chose, must build: its failure (a
    // shader that does not compile, a light it refuses) is an error that keeps the last
    // frame, not a silent fall-back to unshadowed. A light already falling back stays so.
    std::vector<uint32_t> moved;
    config::RenderConfig strict = pose(moved);
    for (size_t i = 0; i < strict.lights.size(); ++i) {
        const bool drew = renderer_ && i < renderer_->lightCount() && !renderer_->techniqueName(i).empty();
        const bool chosen = i >= shown_.lights.size() || shown_.lights[i].shadow.technique != strict.lights[i].shadow.technique;
        if (drew || chosen) strict.lights[i].shadow.required = true;
    }
    // The scene's resources stay unless the draw batching changed or shaders are reloaded
    // (the engine's pipelines are made from them); then no technique is kept either.
    const bool fresh = reloadAll_ || resources_->batching() != frame::SceneResources::batchingOf(strict);
    std::shared_ptr<frame::SceneResources> resources =
        fresh ? std::make_shared<frame::SceneResources>(context_, run_->scene, frame::SceneResources::batchingOf(strict))
              : resources_;
    auto renderer = std::make_unique<frame::FrameRenderer>(resources, strict, newPlugins_ ? *newPlugins_ : *plugins_,
                                                           fresh ? nullptr : renderer_.get());
    renderer->setVisibilityReadBack(!visibilityWanted_ || visibilityWanted_());
    // The scene's nodes were posed in place: the shared upload, BVH and kept techniques
    // take the instances that moved (a renderer of new resources drew them posed already).
    if (!fresh && !moved.empty()) renderer->update(strict, run_->scene, moved);
    if (!shownImage_.empty()) {
        const std::vector<std::string> names = renderer->imageNames();
        if (std::find(names.begin(), names.end(), shownImage_) != names.end()) renderer->requestImage(shownImage_);
    }
    for (const std::string& warning : renderer->warnings()) spdlog::warn("{}", warning);
    return renderer;
}

Session::FrameProgress Session::frameProgress() const
{
    FrameProgress p;
    p.drawing = drawing_;
    p.rebuild = drawingRebuild_;
    p.passes = progress_.passes.load();
    p.fraction = progress_.fraction.load();
    p.seconds = drawing_ ? std::chrono::duration<double>(std::chrono::steady_clock::now() - frameStart_).count() : 0.0;
    return p;
}

bool Session::visibilityKept() const
{
    if (!renderer_) return false;
    for (size_t l = 0; l < renderer_->lightCount(); ++l)
        if (renderer_->visibilityInShading(l)) return false;
    return true;
}

bool Session::renderIfChanged(bool always)
{
    if (!renderer_) return false;
    const bool wanted = !visibilityWanted_ || visibilityWanted_();
    if (pending_ == Change::None && !always && !(wanted && !visibilityKept())) return false;
    const Change change = pending_;
    pending_ = Change::None;
    // Long passes report to progress_ (and poll it for a cancel) while the frame draws.
    const plugin::ProgressScope progressScope(progress_);
    progress_.passes = 0;
    progress_.fraction = 0.0;
    progress_.cancelled = false;
    frameStart_ = std::chrono::steady_clock::now();
    drawing_ = true;
    drawingRebuild_ = change == Change::Renderer;
    struct NotDrawing {
        bool& drawing;
        ~NotDrawing() { drawing = false; }
    } notDrawing{drawing_};
    try {
        if (change == Change::Renderer) {
            // The new renderer draws its first frame before it replaces the old one: a
            // failure anywhere leaves the old one, untouched, with what it drew.
            const auto start = std::chrono::steady_clock::now();
            std::unique_ptr<frame::FrameRenderer> fresh = build();
            frame::FrameTimings timings = fresh->renderFrame();
            lastRebuildMs_ = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
            renderer_ = std::move(fresh);
            resources_ = renderer_->sharedResources();
            reloadAll_ = false;
            timings_ = std::move(timings);
            if (newPlugins_) {
                // The reloaded plugins drew: they are the session's from now on.
                plugins_ = newPlugins_;
                newPlugins_ = nullptr;
                techniques_.reset();
                spdlog::info("reloaded the plugins");
            }
            const std::vector<std::string> names = renderer_->imageNames();
            if (std::find(names.begin(), names.end(), shownImage_) == names.end()) shownImage_.clear();
        } else {
            if (change == Change::View) {
                std::vector<uint32_t> moved;
                const config::RenderConfig& posed = pose(moved);
                renderer_->update(posed, run_->scene, moved);
            }
            // The renderer follows what is wanted only as it draws (a new one is built
            // so): its images, the colour shown between frames among them, stay until then.
            renderer_->setVisibilityReadBack(wanted);
            timings_ = renderer_->renderFrame();
        }
        shown_ = config_;
        drawnCamera_ = run_->config.camera;
        lastFrameSeconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - frameStart_).count();
        // A build's error stays until a build succeeds (the shader is still broken while
        // the camera moves); an update's until the next update or build.
        if (change == Change::Renderer || (change == Change::View && !errorFromBuild_)) lastError_.clear();
    } catch (const Error& e) {
        if (progress_.cancelled) {
            // Not a failure: the user gave up on the frame. The edit goes, as a refused one.
            const FrameProgress p = frameProgress();
            cancelNotice_ = fmt::format("A: cancelled after {:.1f} s{}; the last complete image stays{}", p.seconds,
                                        p.passes > 0 ? fmt::format(" at {:.0f} % of its long pass", 100.0 * p.fraction) : "",
                                        change == Change::Renderer ? " and the edit is undone" : "");
            spdlog::info("{} ({})", cancelNotice_, e.what());
            progress_.cancelled = false;
        } else {
            lastError_ = e.what();
            errorFromBuild_ = change == Change::Renderer;
            spdlog::error("{}", lastError_);
        }
        newPlugins_ = nullptr;  // reloaded plugins that do not build are not taken
        config_ = shown_;
        if (change == Change::View) {
            // A failed or cancelled update: the renderer goes back to the camera and lights
            // it drew (a technique that caches, as the reference does, draws them at once).
            try {
                std::vector<uint32_t> moved;
                renderer_->update(pose(moved), run_->scene, moved);
                timings_ = renderer_->renderFrame();
            } catch (const Error& again) {
                spdlog::error("{}", again.what());
            }
        }
        return false;
    }
    ++framesRendered_;
    return true;
}

std::vector<fs::path> Session::shaderFolders()
{
    std::vector<fs::path> folders = {gpu::engineShaderDir()};
    for (const config::LightConfig& light : config_.lights) {
        if (light.shadow.unshadowed()) continue;
        try {
            folders.push_back(plugins_->load(light.shadow.technique).shaderDir);
        } catch (const Error&) {
            // A plugin that does not load has no shaders to watch; the renderer says why.
        }
    }
    // As ShaderWatcher::folders() keeps them, so that an unchanged set compares equal.
    std::sort(folders.begin(), folders.end());
    folders.erase(std::unique(folders.begin(), folders.end()), folders.end());
    return folders;
}

void Session::save(const fs::path& file)
{
    // Every value explicit, a technique's parameters too (defaults included): the file
    // does not depend on a plugin's defaults, which may change.
    config::RenderConfig c = shown_;
    for (config::LightConfig& light : c.lights) {
        if (light.shadow.unshadowed()) continue;
        const plugin::ParamValues values = plugin::resolveParams(plugins_->load(light.shadow.technique), light.shadow);
        std::vector<config::ShadowParam> params;
        const nlohmann::json all = values.toJson();
        for (const auto& [name, value] : all.items()) params.push_back({name, value, "viewer: save"});
        light.shadow.params = std::move(params);
    }
    config::saveConfig(c, file);
    spdlog::info("saved {}", file.string());
}

} // namespace penumbra::viewer
