#pragma once
// What the viewer shows: one config, edited in place, its scene with the resources that
// depend only on it (frame::SceneResources: the scene on the GPU, the BVH, shaders and
// the engine's pipelines), and the FrameRenderer that draws it — the same renderer and
// render graph `penumbra render` uses. Edits are classed by what they invalidate: a
// camera or light that moved is an update of the renderer; a technique, parameter,
// culling mode, size or debug image builds a new renderer over the same scene resources,
// which keeps the technique instances of the lights the edit did not touch (and keeps
// the old renderer, and the config it drew, when that fails); another scene, a draw
// batching or a shader reload builds everything. Nothing is rendered while nothing changed.
#include "CameraControl.h"

#include "penumbra/config/Config.h"
#include "penumbra/frame/FrameRenderer.h"
#include "penumbra/gpu/Context.h"
#include "penumbra/plugin/PluginRegistry.h"
#include "penumbra/plugin/Progress.h"

#include <chrono>
#include <functional>
#include <utility>

#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace penumbra::viewer {

enum class Change {
    None,
    View,      // the camera, or a light's placement, intensity or colour: FrameRenderer::update
    Renderer,  // techniques, parameters, culling, size, light types, debug images: a new FrameRenderer
};

// A config that frames a glTF file: the camera looks at its bounds from above and aside,
// near plane relative to their size; its own lights (KHR_lights_punctual) when it has
// some, else a sun (directional, 0.53 degrees, hard shadows).
config::RenderConfig configForGltf(const std::filesystem::path& file, const scene::Scene& scene,
                                   const std::vector<scene::GltfLight>& fileLights);

class Session {
public:
    Session(gpu::Context& context, plugin::PluginRegistry& plugins);
    ~Session();

    // Opens a scene config (.json) or a glTF file (.gltf, .glb). Throws Error naming the
    // file; the session keeps what it showed before.
    void open(const std::filesystem::path& file);
    bool isOpen() const { return renderer_ != nullptr; }
    const std::filesystem::path& file() const { return file_; }

    // The config to edit. After an edit, say what changed (the larger change wins until
    // the next frame).
    config::RenderConfig& config() { return config_; }
    const config::RenderConfig& config() const { return config_; }
    const scene::Scene& scene() const { return run_->scene; }
    // Animation (the config's tracks, config/Animation.h): the edited config is the rest
    // pose, and a frame shows it posed at time() (0 .. duration(), the last key).
    float time() const { return time_; }
    void setTime(float seconds);
    float duration() const;

    // The config as the renderer last drew it.
    const config::RenderConfig& shownConfig() const { return shown_; }
    // shownConfig() as the window draws it: without its camera tracks while the camera is
    // free (what B must draw to show the same view).
    config::RenderConfig shownView() const;

    // Camera tracks (/camera/...): the window follows them (after open, after a recording)
    // or the camera is free. Freeing it starts from the pose drawn last, so nothing jumps.
    bool followsCameraTrack() const { return follow_ == CameraFollow::Track && hasCameraTrack(config_.animation); }
    void setCameraFollow(CameraFollow follow);
    // The camera of the last frame drawn (a followed track's pose): what the panels show.
    const scene::Camera& drawnCamera() const { return drawnCamera_; }
    // Where a move starts: the drawn pose while following, else config().camera (edits not
    // drawn yet included).
    const scene::Camera& viewCamera() const { return followsCameraTrack() ? drawnCamera_ : config_.camera; }
    // Places the camera; a followed track is left (the camera is free from then on).
    // Returns whether it was followed.
    bool moveCamera(const scene::Camera& camera);
    void changed(Change change);

    // One technique parameter of light `light`, checked against the plugin's reflection
    // (plugin::ParamValues::set): throws ConfigError naming `where` for a bad value and
    // leaves the config as it was.
    void setParam(size_t light, const std::string& name, const nlohmann::json& value, const std::string& where);
    // Switches light `light` to another technique ("none" for unshadowed); the parameters
    // it had for each technique come back when it returns to it.
    void setTechnique(size_t light, const std::string& technique);
    // Adds a light (at most config::kMaxLights) / removes one (not the last): animation
    // tracks of a removed light go with it, and those of later lights are renumbered.
    void addLight(config::LightConfig light);
    void removeLight(size_t light);

    // The light's current parameter values (defaults filled in), or none for "none" or a
    // plugin that does not load (lastError() says why).
    std::optional<plugin::ParamValues> params(size_t light);

    // The graph image shown instead of the colour ("" for the colour image).
    void showImage(const std::string& name);
    const std::string& shownImage() const { return shownImage_; }

    // Whether the lights' visibility images must be there to read (the pixel inspector, a
    // comparison, a shown image, `save-visibility`): asked before each frame is drawn.
    // Where it says no, shading evaluates the visibility of each light whose technique
    // gives it as a function and no image of it is written
    // (FrameRenderer::setVisibilityReadBack); where it says yes and the last frame kept
    // none, renderIfChanged draws the frame again with them. Unset: always yes.
    void setVisibilityWanted(std::function<bool()> wanted) { visibilityWanted_ = std::move(wanted); }
    // Whether the last frame kept every light's visibility image (readVisibility and
    // readPixel work for every light).
    bool visibilityKept() const;

    // Renders a frame when something changed since the last one (or `always`), or when
    // the visibility images are wanted and the last frame kept none. A failed
    // rebuild (a shader that does not compile, a technique that refuses a light, a plugin
    // that does not load) keeps the renderer and config of the last good frame, with the
    // message in lastError() ("path:line: error: ..." for a shader). Returns whether a new
    // frame was rendered.
    bool renderIfChanged(bool always);
    // Builds the renderer again from disk: its shaders (hot reload), the engine's pipelines
    // and every technique.
    void reload()
    {
        reloadAll_ = true;
        changed(Change::Renderer);
    }
    // Builds the renderer with another registry (reloaded plugin libraries: PluginReloader),
    // which must outlive the session; taken only if that renderer draws, else the current
    // one stays, with the error. The config, and so every light's parameters, stays.
    void usePlugins(plugin::PluginRegistry& plugins);
    plugin::PluginRegistry& plugins() { return *plugins_; }
    // The folders the frame's shaders come from: the engine's and each technique plugin's,
    // sorted, each once.
    std::vector<std::filesystem::path> shaderFolders();

    // A's long frames (plugin/Progress.h): `onReport` is called on this thread while a long
    // pass of a frame runs (every few tens of milliseconds), so that the window is drawn
    // meanwhile (Viewer::drawBusyFrame); it must not edit or render the session.
    void setProgressListener(std::function<void()> onReport) { progress_.onReport = std::move(onReport); }
    struct FrameProgress {
        bool drawing = false;   // a frame is in flight (renderIfChanged has not returned)
        bool rebuild = false;   // of a new renderer: renderer() still holds the last complete frame
        uint32_t passes = 0;    // long passes that reported so far
        double fraction = 0.0;  // of the one reporting now
        double seconds = 0.0;   // since the frame began
    };
    FrameProgress frameProgress() const;
    // Asks the frame in flight to stop (a pass that polls stops at its next unit of work):
    // the last complete frame, and the config it drew, stay; the edit is undone.
    void cancelFrame() { progress_.cancelled = true; }
    // Once, after a cancelled frame: what was cancelled, and that the last image stays.
    std::string takeCancelNotice() { return std::exchange(cancelNotice_, {}); }
    // The wall clock of the last frame drawn (a rebuild's: building and drawing).
    double lastFrameSeconds() const { return lastFrameSeconds_; }

    frame::FrameRenderer& renderer() { return *renderer_; }
    const frame::FrameTimings& lastTimings() const { return timings_; }
    uint64_t framesRendered() const { return framesRendered_; }
    // From an edit that needs a new renderer to its first frame drawn (ms): what a
    // parameter change costs before the image shows it.
    double lastRebuildMs() const { return lastRebuildMs_; }
    const std::string& lastError() const { return lastError_; }
    void clearError() { lastError_.clear(); }

    // Every plugin that loads, for the technique menus (and "none").
    std::vector<std::string> techniqueNames();

    // Saves the config as shown (config::saveConfig: replaced complete or not at all).
    void save(const std::filesystem::path& file);

private:
    std::unique_ptr<frame::FrameRenderer> build();
    // The config a frame draws: config() posed at time() (the scene's nodes too; its camera
    // tracks left out while the camera is free); `moved`
    // gets the instances that moved, for FrameRenderer::update.
    const config::RenderConfig& pose(std::vector<uint32_t>& moved) const;

    gpu::Context& context_;
    plugin::PluginRegistry* plugins_;              // the one the renderer was built with
    plugin::PluginRegistry* newPlugins_ = nullptr;  // usePlugins(): taken once a renderer built with it draws
    std::filesystem::path file_;
    std::unique_ptr<config::PreparedRun> run_;  // the scene (and the config as it was read)
    config::RenderConfig config_;               // as edited
    config::RenderConfig shown_;                // as the renderer last drew it (a failed edit returns to it)
    std::shared_ptr<frame::SceneResources> resources_;  // of run_->scene, for renderer_
    std::unique_ptr<frame::FrameRenderer> renderer_;
    Change pending_ = Change::None;
    bool reloadAll_ = false;  // the next build starts from new scene resources, keeping no technique
    std::string shownImage_;
    std::function<bool()> visibilityWanted_;
    frame::FrameTimings timings_;
    uint64_t framesRendered_ = 0;
    std::string lastError_;
    bool errorFromBuild_ = false;
    float time_ = 0.0f;
    double lastRebuildMs_ = 0.0;
    CameraFollow follow_ = CameraFollow::Track;
    plugin::ProgressSink progress_;  // A's frame in flight
    std::chrono::steady_clock::time_point frameStart_{};
    bool drawing_ = false, drawingRebuild_ = false;
    double lastFrameSeconds_ = 0.0;
    std::string cancelNotice_;
    scene::Camera drawnCamera_;
    // Per light, the parameters each technique had when the light left it.
    std::vector<std::map<std::string, std::vector<config::ShadowParam>>> paramsByTechnique_;
    std::optional<std::vector<std::string>> techniques_;
};

} // namespace penumbra::viewer
