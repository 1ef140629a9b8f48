#pragma once
// penumbra-viewer: a window (GLFW, Vulkan swapchain: Presenter.h) showing one Session
// (Session.h: a config, its scene, the FrameRenderer) with Dear ImGui panels to edit it,
// driven by the mouse and keys or by a script (Script.h). Viewer.cpp has the loop and the
// input, ViewerCommands.cpp the script commands (one table: CommandTable.h), Panels.cpp the
// panels; the A/B comparison's state is Comparison.h's.
#include "CameraControl.h"
#include "CommandTable.h"
#include "Comparison.h"
#include "PluginReloader.h"
#include "Presenter.h"
#include "Script.h"
#include "Session.h"
#include "ShaderWatcher.h"

#include "penumbra/gpu/Context.h"
#include "penumbra/metrics/DebugImage.h"
#include "penumbra/plugin/PluginRegistry.h"

#include <chrono>
#include <deque>
#include <functional>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

struct GLFWwindow;

namespace penumbra::viewer {

struct ViewerOptions {
    std::filesystem::path file;  // a scene config or a glTF file
    std::vector<ScriptCommand> script;
    bool vsync = true;
    uint32_t windowWidth = 0, windowHeight = 0;  // 0: the frame's size plus the panel
    gpu::ContextOptions context;
};

// Opens the window and runs until it is closed or the script says `quit` (a script that
// ends without `quit` leaves the window open). Returns the process's exit code: 0, 1 for
// an error (no display, a script command that failed: logged with where), 3 when the
// validation layer reported anything.
int runViewer(const ViewerOptions& options);

// Rolling per-pass timings for the panel: the last kHistory frames of each pass.
struct TimingHistory {
    static constexpr size_t kHistory = 120;
    std::map<std::string, std::deque<float>> gpuMs, cpuMs;
    std::deque<float> frameMs, sumGpuMs, viewerMs;
    // Per shown frame, the panels' own cost: building them (Dear ImGui's frame, 0 when
    // they were not due) and their GPU time (drawn, or copied from their layer).
    std::deque<float> panelsCpuMs, panelsGpuMs;
    std::deque<float> shownMs;  // wall clock from one shown frame to the next
    std::vector<std::string> order;  // passes in execution order, as last seen
    void add(const frame::FrameTimings& timings);
    static void push(std::deque<float>& values, float value);
    static float median(const std::deque<float>& values);
    static float mean(const std::deque<float>& values);
    // The panels' mean cost per shown frame over the median frame, in percent.
    float panelsShare() const;
};

class Viewer {
public:
    // Creates the device (with presentation), opens the file and the window. Throws Error.
    explicit Viewer(const ViewerOptions& options);
    ~Viewer();
    int run();

    // The script commands (ViewerCommands.cpp): what the script runs through, what
    // runViewer checks a script against before the window opens, and what
    // `--list-commands` prints for docs/viewer.md.
    static const CommandTable<Viewer>& commands();

private:
    // Viewer.cpp
    void frame();
    // Whether this frame builds the panels again (Dear ImGui's frame: widgets, input):
    // after input, while a button or key is held, after a change the panels show, and at
    // least every kPanelRefreshS; between, the presenter shows the panels as last drawn.
    bool panelsDue(double now) const;
    static void countInput(GLFWwindow* window);  // a GLFW input callback's count
    // Panels.cpp: a panel's collapsing header; a script can open or close it (`panel`).
    bool panelHeader(const char* name, bool openAtFirst);
    static std::string panelKey(std::string name);  // a panel's name as `panel` takes it: lower case
    void handleInput();
    bool runScriptUntilFrame();  // false when the script quit
    void printTimings();         // `timings`
    // `wait-for` and its kind: frames run until `condition` holds (at most 120 s).
    void waitUntil(const ScriptCommand& command, std::function<bool()> condition);
    void fitRenderSize();
    void afterRender();
    std::vector<ViewBlit> viewBlits() const;
    // The view as shown (the frame, the mapped debug image, B or the difference), RGBA8.
    std::vector<uint8_t> viewPixels(uint32_t& width, uint32_t& height);
    void writeScreenshot(const std::filesystem::path& file, bool window);
    size_t lightIndex(const std::string& nameOrIndex, const ScriptCommand& command) const;
    // Places the camera (Session::moveCamera), saying so when that left a followed track.
    void moveCamera(const scene::Camera& camera);
    float sceneRadius() const;
    static std::optional<VkRect2D> monitorWorkArea();
    void fitFrameIntoWorkArea(const VkRect2D& workArea);

    // Panels.cpp
    void drawPanels();
    void drawFilePanel();
    void drawScenePanel();
    void drawCameraPanel();
    void drawRenderPanel();
    void drawLightsPanel();
    void drawTechniquePanel(size_t light);
    void drawParamWidgets(const std::string& key, const std::string& lightName, const plugin::ParamValues& values,
                          const std::function<void(const plugin::ParamSpec&, const nlohmann::json&)>& apply);
    void drawComparePanel();
    void drawAnimationPanel();

    // Animation playback and camera recording (item: a camera path saved as tracks).
    void startRecording();
    void stopRecording();
    void recordCameraKey();
    void drawDebugImagePanel();
    void drawTimingsPanel();
    void drawPixelInspector();
    void drawDifferenceColourBar();
    // The pixel inspector's text for frame pixel (x, y): colour and every light's V (and B's
    // and the difference, when B is of this view). `inspect X Y` prints it.
    std::string pixelReport(uint32_t x, uint32_t y);

    // A's long frames (Session::setProgressListener): the window is drawn meanwhile — the
    // panels as last drawn, the last complete image, an overlay with the progress and Cancel.
    void onFrameProgress();
    void drawBusyOverlay(const Session::FrameProgress& progress);
    std::vector<ViewBlit> busyBlits(bool rebuild) const;
    static constexpr double kBusyAfterS = 0.25;  // a frame drawn faster draws no window frame
    static constexpr double kBusyFrameS = 0.05;  // at most 20 window frames a second meanwhile
    static constexpr double kKeepFrameS = 0.2;   // a frame this slow is copied (shown while the next draws)
    static constexpr float kBackground[3] = {0.09f, 0.09f, 0.1f};
    uint64_t busyFrames_ = 0;  // window frames drawn inside A's frames, since start
    double busyDrawnAt_ = -1.0;
    Session::FrameProgress busyLastProgress_;
    std::optional<double> cancelAfterS_;  // `cancel-after SECONDS`
    std::unique_ptr<UploadedImage> lastCompleteUpload_, busyBackdrop_;
    // Whose frame lastCompleteUpload_ holds: the renderer and its frame count.
    std::optional<std::pair<const frame::FrameRenderer*, uint64_t>> lastComplete_;

    ViewerOptions options_;
    GLFWwindow* window_ = nullptr;
    std::unique_ptr<gpu::Context> context_;
    std::unique_ptr<plugin::PluginRegistry> plugins_;
    // Hot reload of plugin libraries: every registry made stays (libraries stay loaded).
    std::unique_ptr<PluginReloader> pluginReloader_;
    std::vector<std::unique_ptr<plugin::PluginRegistry>> reloadedPlugins_;
    std::chrono::steady_clock::time_point pluginsCheckedAt_{};
    std::unique_ptr<Session> session_;
    std::unique_ptr<Presenter> presenter_;
    std::unique_ptr<UploadedImage> debugUpload_;

    // The view: where in the window the frame is shown, and the render size.
    VkRect2D viewRect_{};
    float panelWidth_ = 440.0f;
    std::optional<std::pair<uint32_t, uint32_t>> fixedSize_;  // `size W H` / the panel: the frame does not follow the window
    float uiScale_ = 1.0f;

    // Debug image display.
    metrics::DebugMapping mapping_ = metrics::DebugMapping::Linear;
    bool autoRange_ = true;
    metrics::DebugRange range_{};
    std::optional<metrics::DebugImageValues> shownValues_;  // of the last frame, when a debug image is shown
    // Its place in the view: zoom (1: fitted, aspect kept) and pan (window pixels); the
    // wheel zooms and a drag pans it; showing an image resets them and the mapping.
    double debugZoom_ = 1.0;
    glm::dvec2 debugPan_{0.0};
    bool debugMappingChosen_ = false;  // else the image's default (afterRender)
    std::vector<std::pair<float, uint64_t>> debugClasses_;  // a classification's values (its legend)
    VkRect2D viewArea_{};  // the window less the panel
    bool debugImageBlit(VkExtent2D image, VkRect2D& target, VkRect2D& source) const;
    void resetDebugView();
    static std::vector<std::pair<float, uint64_t>> imageClasses(const metrics::DebugImageValues& image);

    // Pixel inspector: read back lazily, per rendered frame.
    uint64_t inspectedFrame_ = ~0ull;
    std::optional<frame::FrameRenderer::Pixel> inspected_;  // the pixel inspector's last read
    std::pair<uint32_t, uint32_t> inspectedAt_{};
    const frame::FrameRenderer* inspectedRenderer_ = nullptr;
    // What reads the lights' visibility images (Session::setVisibilityWanted): the pixel
    // inspector while the cursor is over the view, a comparison, a shown image, and a
    // command that reads them (drawWithVisibility). With none, shading evaluates V and no
    // image of it is written.
    bool inspecting_ = false;
    bool visibilityPinned_ = false;
    bool wantsVisibility() const;
    // Draws the frame again if it kept no visibility images (a command about to read them).
    void drawWithVisibility();

    CameraMode cameraMode_ = CameraMode::Orbit;
    scene::Camera homeCamera_;  // as the file gave it: R goes back to it
    scene::Camera panelCamera_;  // the pose the camera panel showed last (`print-camera`)
    double lastTime_ = 0.0;
    float flySpeedExponent_ = 0.0f;
    bool continuous_ = false;
    bool showUi_ = true;
    std::map<std::string, bool> panelOpen_;  // `panel NAME open|closed` to apply, by lower-case name
    // Input events since start (GLFW's callbacks count them) and the count the last
    // panels saw; a change the panels show that no input made (a script command, a new
    // frame after an edit, a message) sets panelsDirty_.
    uint64_t inputEvents_ = 0;
    uint64_t inputEventsSeen_ = 0;
    bool panelsDirty_ = true;
    double panelsBuiltAt_ = -1.0;
    static constexpr double kPanelRefreshS = 0.25;  // live figures (timings, time) refresh 4x a second
    bool quit_ = false;
    int exitCode_ = 0;
    std::string savePath_;
    std::string openPath_;
    std::string message_;  // the last save / screenshot / error, for the status line
    TimingHistory history_;
    std::map<std::string, double> editing_;
    // The technique parameter widgets the last panels drew: "light param type" (`widgets`).
    std::vector<std::string> drawnParamWidgets_;  // technique parameters being dragged, by light/technique/name

    ShaderWatcher shaderWatcher_;

    bool playing_ = false;
    bool recording_ = false;
    std::chrono::steady_clock::time_point recordStart_{};
    config::AnimationTrack recordedPosition_, recordedTarget_;

    // The second stack, B (Comparison.h), and its images as the view shows them (uploaded
    // when their versions move on).
    Comparison comparison_;
    std::unique_ptr<UploadedImage> bUpload_, differenceUpload_;
    uint64_t bUploaded_ = 0, differenceUploaded_ = 0;
    bool waitCompare_ = false;  // `wait-compare`: frames run until B of the current view is in
    std::chrono::steady_clock::time_point waitCompareDeadline_{};
    // B drawing every light with `technique` (a plugin that does not load throws, naming it).
    void startComparison(const std::string& technique);
    void updateComparison();
    void uploadComparisonImages();

    size_t scriptNext_ = 0;
    // `wait-for FILE`, `wait-error TEXT`, `wait-no-error`: frames run until it holds.
    std::function<bool()> waitUntil_;
    std::string waitWhat_;
    std::chrono::steady_clock::time_point waitDeadline_{};
    int framesToRun_ = 0;  // `frames N`: loop iterations before the next command
};

} // namespace penumbra::viewer
