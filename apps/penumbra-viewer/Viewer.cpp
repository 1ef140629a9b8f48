#include "Viewer.h"

#include "VisibilityExr.h"  // apps/penumbra: the CLI's float V output

#include "penumbra/config/Overrides.h"
#include "penumbra/core/Error.h"
#include "penumbra/core/ShortText.h"
#include "penumbra/io/Png.h"
#include "penumbra/metrics/Images.h"
#include "penumbra/plugin/Params.h"

#define GLFW_INCLUDE_NONE
#define GLFW_INCLUDE_VULKAN
#include <GLFW/glfw3.h>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <imgui.h>
#include <imgui_internal.h>  // ImGuiContext::WithinFrameScope: no window frame inside Dear ImGui's
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_vulkan.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cctype>
#include <set>
#include <charconv>
#include <chrono>
#include <cmath>

namespace fs = std::filesystem;

namespace penumbra::viewer {
namespace {

std::string glfwErrorText;

void onGlfwError(int code, const char* description)
{
    glfwErrorText = fmt::format("{} (GLFW error {:#x})", description ? description : "unknown", code);
}

// The window system's part of the device: GLFW's instance extensions and its test of
// which queue family can present.
gpu::Presentation glfwPresentation()
{
    uint32_t count = 0;
    const char** names = glfwGetRequiredInstanceExtensions(&count);
    if (!names) {
        throw GpuError(fmt::format("the window system offers no Vulkan surface: {}",
                                   glfwErrorText.empty() ? "GLFW found no Vulkan loader" : glfwErrorText));
    }
    gpu::Presentation presentation;
    presentation.instanceExtensions.assign(names, names + count);
    presentation.canPresent = [](VkInstance instance, VkPhysicalDevice device, uint32_t family) {
        return glfwGetPhysicalDevicePresentationSupport(instance, device, family) == GLFW_TRUE;
    };
    return presentation;
}

float parseFloat(const std::string& text, const ScriptCommand& command)
{
    float value = 0.0f;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (ec != std::errc() || end != text.data() + text.size() || !std::isfinite(value)) {
        throw Error(fmt::format("{}: {}: expected a finite number, got \"{}\"", command.where, command.words[0],
                                core::shortText(text)));
    }
    return value;
}

int parseInt(const std::string& text, const ScriptCommand& command, int lo, int hi)
{
    int value = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (ec != std::errc() || end != text.data() + text.size() || value < lo || value > hi) {
        throw Error(fmt::format("{}: {}: expected a whole number in [{}, {}], got \"{}\"", command.where, command.words[0],
                                lo, hi, core::shortText(text)));
    }
    return value;
}

void expectWords(const ScriptCommand& command, size_t count, const char* usage)
{
    if (command.words.size() != count) {
        throw Error(fmt::format("{}: {}: expected `{}`", command.where, command.words[0], usage));
    }
}

// `VERB on|off`: anything else is an error, not "off".
bool parseOnOff(const ScriptCommand& command, const char* usage)
{
    expectWords(command, 2, usage);
    if (command.words[1] != "on" && command.words[1] != "off") {
        throw Error(fmt::format("{}: {}: expected `{}`, got \"{}\"", command.where, command.words[0], usage,
                                core::shortText(command.words[1])));
    }
    return command.words[1] == "on";
}

glm::vec3 parseVec3(const ScriptCommand& command, size_t first)
{
    return {parseFloat(command.words[first], command), parseFloat(command.words[first + 1], command),
            parseFloat(command.words[first + 2], command)};
}

} // namespace

void TimingHistory::add(const frame::FrameTimings& timings)
{
    order.clear();
    float sum = 0.0f;
    for (const frame::PassTiming& pass : timings.passes) {
        order.push_back(pass.name);
        push(gpuMs[pass.name], float(pass.gpuMs));
        push(cpuMs[pass.name], float(pass.cpuMs));
        sum += float(pass.gpuMs);
    }
    push(sumGpuMs, sum);
    push(frameMs, float(timings.frameCpuMs));
}

void TimingHistory::push(std::deque<float>& values, float value)
{
    values.push_back(value);
    if (values.size() > kHistory) values.pop_front();
}

float TimingHistory::mean(const std::deque<float>& values)
{
    if (values.empty()) return 0.0f;
    double sum = 0.0;
    for (float v : values) sum += v;
    return float(sum / double(values.size()));
}

float TimingHistory::panelsShare() const
{
    const float frame = median(frameMs);
    return frame > 0.0f ? 100.0f * (mean(panelsCpuMs) + mean(panelsGpuMs)) / frame : 0.0f;
}

float TimingHistory::median(const std::deque<float>& values)
{
    if (values.empty()) return 0.0f;
    std::vector<float> v(values.begin(), values.end());
    std::nth_element(v.begin(), v.begin() + long(v.size() / 2), v.end());
    return v[v.size() / 2];
}

Viewer::Viewer(const ViewerOptions& options) : options_(options)
{
    gpu::ContextOptions contextOptions = options.context;
    contextOptions.presentation = glfwPresentation();
    context_ = std::make_unique<gpu::Context>(contextOptions);
    spdlog::info("device: {} ({})", context_->deviceInfo().name, context_->deviceInfo().type);
    plugins_ = std::make_unique<plugin::PluginRegistry>();
    pluginReloader_ = std::make_unique<PluginReloader>(plugin::defaultPluginSearchPath());
    session_ = std::make_unique<Session>(*context_, *plugins_);
    session_->open(options.file);
    homeCamera_ = session_->config().camera;
    savePath_ = options.file.extension() == ".json" ? options.file.string() : options.file.stem().string() + ".json";
    openPath_ = options.file.string();

    glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);
    glfwWindowHint(GLFW_RESIZABLE, GLFW_TRUE);
    glfwWindowHint(GLFW_SCALE_TO_MONITOR, GLFW_TRUE);  // HiDPI: the window's size in screen points
    uint32_t width = options.windowWidth ? options.windowWidth : session_->config().width + uint32_t(panelWidth_);
    uint32_t height = options.windowHeight ? options.windowHeight : session_->config().height;
    const std::optional<VkRect2D> workArea = monitorWorkArea();
    if (workArea && !options.windowWidth && !options.windowHeight) {
        // The frame's size plus the panel, within the screen (the frame follows the window).
        width = std::min(width, workArea->extent.width);
        height = std::min(height, workArea->extent.height);
    }
    window_ = glfwCreateWindow(int(width), int(height), fmt::format("Penumbra — {}", options.file.filename().string()).c_str(),
                               nullptr, nullptr);
    if (!window_) throw GpuError(fmt::format("cannot open a window: {}", glfwErrorText));
    if (workArea && !options.windowWidth && !options.windowHeight) fitFrameIntoWorkArea(*workArea);
    float xs = 1.0f, ys = 1.0f;
    glfwGetWindowContentScale(window_, &xs, &ys);
    uiScale_ = std::clamp(std::max(xs, ys), 1.0f, 4.0f);

    IMGUI_CHECKVERSION();
    ImGui::CreateContext();
    ImGuiIO& io = ImGui::GetIO();
    io.IniFilename = nullptr;  // the layout is the program's; no file is written beside the user's
    io.FontGlobalScale = uiScale_;
    ImGui::StyleColorsDark();
    ImGui::GetStyle().ScaleAllSizes(uiScale_);
    // Every input event wakes the panels (panelsDue); Dear ImGui's backend installs its own
    // callbacks over these and calls them on.
    glfwSetWindowUserPointer(window_, this);
    glfwSetMouseButtonCallback(window_, [](GLFWwindow* w, int, int, int) { countInput(w); });
    glfwSetScrollCallback(window_, [](GLFWwindow* w, double, double) { countInput(w); });
    glfwSetKeyCallback(window_, [](GLFWwindow* w, int, int, int, int) { countInput(w); });
    glfwSetCharCallback(window_, [](GLFWwindow* w, unsigned int) { countInput(w); });
    glfwSetWindowFocusCallback(window_, [](GLFWwindow* w, int) { countInput(w); });
    glfwSetCursorEnterCallback(window_, [](GLFWwindow* w, int) { countInput(w); });
    glfwSetCursorPosCallback(window_, [](GLFWwindow* w, double, double) { countInput(w); });
    glfwSetFramebufferSizeCallback(window_, [](GLFWwindow* w, int, int) { countInput(w); });
    ImGui_ImplGlfw_InitForVulkan(window_, true);
    presenter_ = std::make_unique<Presenter>(*context_, window_, options.vsync);
    debugUpload_ = std::make_unique<UploadedImage>(*context_, "viewer debug image");
    bUpload_ = std::make_unique<UploadedImage>(*context_, "viewer B image");
    differenceUpload_ = std::make_unique<UploadedImage>(*context_, "viewer difference image");
    lastCompleteUpload_ = std::make_unique<UploadedImage>(*context_, "viewer last complete frame");
    busyBackdrop_ = std::make_unique<UploadedImage>(*context_, "viewer busy backdrop");
    busyBackdrop_->set(1, 1, {uint8_t(kBackground[0] * 255.0f), uint8_t(kBackground[1] * 255.0f), uint8_t(kBackground[2] * 255.0f), 255});
    session_->setProgressListener([this] { onFrameProgress(); });
    lastTime_ = glfwGetTime();
}

// The primary monitor's work area (the screen less task bars and docks), in the window's
// size units (screen coordinates over the content scale, as GLFW_SCALE_TO_MONITOR sizes a
// window); none without a monitor.
std::optional<VkRect2D> Viewer::monitorWorkArea()
{
    GLFWmonitor* monitor = glfwGetPrimaryMonitor();
    if (!monitor) return std::nullopt;
    int x = 0, y = 0, w = 0, h = 0;
    glfwGetMonitorWorkarea(monitor, &x, &y, &w, &h);
    float xs = 1.0f, ys = 1.0f;
    glfwGetMonitorContentScale(monitor, &xs, &ys);
    if (w <= 0 || h <= 0) return std::nullopt;
    const float scale = std::clamp(std::max(xs, ys), 1.0f, 4.0f);
    return VkRect2D{{x, y}, {uint32_t(float(w) / scale), uint32_t(float(h) / scale)}};
}

// A window manager's title bar and borders come on top of the window's size: the window
// shrinks by them, and moves into the work area, when they would reach past it.
void Viewer::fitFrameIntoWorkArea(const VkRect2D& workArea)
{
    int left = 0, top = 0, right = 0, bottom = 0, w = 0, h = 0;
    glfwGetWindowFrameSize(window_, &left, &top, &right, &bottom);
    glfwGetWindowSize(window_, &w, &h);
    const int maxW = int(workArea.extent.width) - left - right, maxH = int(workArea.extent.height) - top - bottom;
    if ((w > maxW || h > maxH) && maxW > 0 && maxH > 0) {
        glfwSetWindowSize(window_, std::min(w, maxW), std::min(h, maxH));
        glfwSetWindowPos(window_, workArea.offset.x + left, workArea.offset.y + top);
    }
}

Viewer::~Viewer()
{
    comparison_.reset();  // joins its thread (after the frame in flight)
    if (context_ && context_->device()) vkDeviceWaitIdle(context_->device());
    debugUpload_.reset();
    bUpload_.reset();
    differenceUpload_.reset();
    lastCompleteUpload_.reset();
    busyBackdrop_.reset();
    presenter_.reset();  // shuts ImGui's Vulkan backend down
    if (ImGui::GetCurrentContext()) {
        ImGui_ImplGlfw_Shutdown();
        ImGui::DestroyContext();
    }
    session_.reset();
    if (window_) glfwDestroyWindow(window_);
}

float Viewer::sceneRadius() const
{
    const float r = session_->scene().bounds().radius();
    return std::isfinite(r) && r > 0.0f ? r : 1.0f;
}

int Viewer::run()
{
    while (!quit_ && !glfwWindowShouldClose(window_)) {
        const bool scripted = scriptNext_ < options_.script.size() || framesToRun_ > 0;
        // Idle without a script and nothing moving: wait for input instead of spinning.
        if (scripted || continuous_) {
            glfwPollEvents();
        } else {
            glfwWaitEventsTimeout(0.1);
        }
        if (!runScriptUntilFrame()) break;
        frame();
    }
    vkDeviceWaitIdle(context_->device());
    const uint32_t bMessages = retiredBValidationMessages_ + (comparison_ ? comparison_->validationMessages() : 0);
    if (bMessages > 0) {
        spdlog::error("the Vulkan validation layer reported {} message(s) on the comparison's device", bMessages);
        if (exitCode_ == 0) exitCode_ = 3;
    }
    if (context_->validationEnabled() && context_->validationMessageCount() > 0) {
        spdlog::error("the Vulkan validation layer reported {} message(s)", context_->validationMessageCount());
        for (const std::string& m : context_->validationMessages()) spdlog::error("  {}", m);
        if (exitCode_ == 0) exitCode_ = 3;
    }
    return exitCode_;
}

void Viewer::countInput(GLFWwindow* window) { ++static_cast<Viewer*>(glfwGetWindowUserPointer(window))->inputEvents_; }

bool Viewer::panelsDue(double now) const
{
    if (!presenter_->panelLayer() || panelsDirty_ || inputEvents_ != inputEventsSeen_ ||
        now - panelsBuiltAt_ >= kPanelRefreshS) {
        return true;
    }
    // Held: a drag, or a fly key, moves something every frame without new events.
    const ImGuiIO& io = ImGui::GetIO();
    return std::any_of(std::begin(io.MouseDown), std::end(io.MouseDown), [](bool d) { return d; }) ||
           std::any_of(std::begin(io.KeysDown), std::end(io.KeysDown), [](bool d) { return d; });
}

void Viewer::frame()
{
    const double now = glfwGetTime();
    const float dt = float(std::clamp(now - lastTime_, 0.0, 0.25));
    TimingHistory::push(history_.shownMs, float((now - lastTime_) * 1000.0));
    lastTime_ = now;
    const std::string messageBefore = message_;
    // The panels, and the input that reaches the camera through Dear ImGui, only when due.
    const bool panels = panelsDue(now);
    // First: its window-system queries wait for the server to finish the last present,
    // a wait that is the present's, not the panels'.
    fitRenderSize();
    const auto uiStart = std::chrono::steady_clock::now();
    if (panels) {
        inputEventsSeen_ = inputEvents_;
        panelsDirty_ = false;
        panelsBuiltAt_ = now;
        ImGui_ImplVulkan_NewFrame();
        ImGui_ImplGlfw_NewFrame();
        ImGui::NewFrame();
        if (showUi_) drawPanels();
    }
    double panelsCpuMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - uiStart).count();
    if (panels) {
        handleInput();
        // Dear ImGui's frame ends before A is drawn: a long frame draws frames of its own
        // meanwhile (drawBusyFrame).
        const auto renderStart = std::chrono::steady_clock::now();
        ImGui::Render();
        panelsCpuMs += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - renderStart).count();
    }
    if (playing_) {
        // Plays at wall-clock speed and loops.
        const float end = session_->duration();
        float t = session_->time() + dt;
        if (t > end) t = end > 0.0f ? std::fmod(t, end) : 0.0f;
        session_->setTime(t);
    }
    if (recording_) recordCameraKey();
    double uiMs = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - uiStart).count();

    // Hot reload: an edited shader builds the frame again; a compile error keeps the last
    // good frame and shows "path:line: error: ..." (Session::renderIfChanged).
    if (shaderWatcher_.changed()) {
        spdlog::info("shader changed: {}; building the frame again", fmt::join(shaderWatcher_.lastChanged(), ", "));
        session_->reload();
    }
    // Rebuilt plugin libraries: loaded from private copies into a new registry.
    if (const auto now = std::chrono::steady_clock::now(); now - pluginsCheckedAt_ >= std::chrono::milliseconds(500)) {
        pluginsCheckedAt_ = now;
        if (pluginReloader_->changed()) {
            spdlog::info("plugin changed: {}; loading the plugins again", fmt::join(pluginReloader_->lastChanged(), ", "));
            try {
                reloadedPlugins_.push_back(pluginReloader_->freshRegistry());
                session_->usePlugins(*reloadedPlugins_.back());
                // B too: a new worker whose registry opens the fresh copies (B's settings stay).
                if (comparison_) {
                    retiredBValidationMessages_ += comparison_->validationMessages();
                    comparison_ = std::make_unique<ComparisonWorker>(options_.context, reloadedPlugins_.back()->searchPath());
                    spdlog::info("B: a new worker with the plugins of {}", reloadedPlugins_.back()->searchPath().front().string());
                    forgetB();
                }
            } catch (const std::exception& e) {
                message_ = e.what();
            }
        }
    }
    // A frame drawn for a change (not the next frame of a continuous run): the panels show
    // what changed (the camera's fields, the technique's figures) on the next frame.
    const uint64_t busyFramesBefore = busyFrames_;
    if (session_->renderIfChanged(continuous_)) {
        afterRender();
        if (!continuous_) panelsDirty_ = true;
    }
    if (!session_->lastError().empty()) message_ = session_->lastError();
    if (std::string notice = session_->takeCancelNotice(); !notice.empty()) message_ = std::move(notice);
    if (busyFrames_ != busyFramesBefore) {
        // The window was drawn while A drew, with Dear ImGui's frames of its own: the panels
        // are built again for the next one, and this one is not shown again.
        spdlog::info("A: {} window frame(s) shown while the frame drew ({:.1f} s)", busyFrames_ - busyFramesBefore,
                     busyLastProgress_.seconds);
        panelsDirty_ = true;
        if (framesToRun_ > 0) --framesToRun_;
        return;
    }
    try {
        updateComparison();
    } catch (const std::exception& e) {
        message_ = fmt::format("B: {}", e.what());  // the window goes on with A alone
        compareOn_ = false;
    }
    if (message_ != messageBefore) panelsDirty_ = true;
    if (const std::vector<fs::path> folders = session_->shaderFolders(); folders != shaderWatcher_.folders()) {
        shaderWatcher_.watch(folders);  // techniques changed: their plugins' folders
    }

    const auto presentStart = std::chrono::steady_clock::now();
    presenter_->present(viewBlits(), ImGui::GetDrawData(), panels, kBackground);
    uiMs += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - presentStart).count();
    TimingHistory::push(history_.viewerMs, float(uiMs));
    TimingHistory::push(history_.panelsCpuMs, panels ? float(panelsCpuMs) : 0.0f);
    if (presenter_->lastTimes().valid) TimingHistory::push(history_.panelsGpuMs, float(presenter_->lastTimes().panelsMs));
    if (framesToRun_ > 0) --framesToRun_;
}

// A long pass of A's frame reported (on this thread, from inside Session::renderIfChanged).
void Viewer::onFrameProgress()
{
    const Session::FrameProgress p = session_->frameProgress();
    busyLastProgress_ = p;
    if (cancelAfterS_ && p.seconds >= *cancelAfterS_) {
        cancelAfterS_.reset();
        spdlog::info("A: cancelling the frame after {:.1f} s at {:.0f} % (cancel-after)", p.seconds, 100.0 * p.fraction);
        session_->cancelFrame();
    }
    const double now = glfwGetTime();
    // A short pass draws no window frame (no flicker); Dear ImGui's frames do not nest.
    if (p.seconds < kBusyAfterS || now - busyDrawnAt_ < kBusyFrameS || GImGui->WithinFrameScope) return;
    busyDrawnAt_ = now;
    ++busyFrames_;
    glfwPollEvents();
    if (glfwWindowShouldClose(window_)) session_->cancelFrame();
    ImGui_ImplVulkan_NewFrame();
    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();
    drawBusyOverlay(p);
    ImGui::Render();
    // The panels as last drawn (their layer), the overlay over the view.
    presenter_->present(busyBlits(p.rebuild), ImGui::GetDrawData(), false, kBackground);
}

// The views while A draws: a rebuild leaves the last renderer and its frame untouched; an
// update draws into the renderer's images, so its colour is the copy of the last slow
// frame (afterRender) or, after a fast one, which was not copied, the background.
std::vector<ViewBlit> Viewer::busyBlits(bool rebuild) const
{
    std::vector<ViewBlit> blits = viewBlits();
    if (rebuild) return blits;
    const gpu::Image* color = &session_->renderer().executor().image("color");
    const bool kept = lastComplete_ && lastComplete_->first == &session_->renderer() &&
                      lastComplete_->second == session_->framesRendered();
    for (ViewBlit& b : blits) {
        if (b.image != color) continue;
        b.image = kept ? &lastCompleteUpload_->image() : &busyBackdrop_->image();
        b.layout = UploadedImage::kLayout;
        if (!kept) b.source = {};
    }
    return blits;
}

void Viewer::startRecording()
{
    // The recorded path replaces the config's camera tracks: they would move the camera
    // away from the one being flown.
    session_->setCameraFollow(CameraFollow::Free);  // from the pose drawn
    auto& tracks = session_->config().animation.tracks;
    tracks.erase(std::remove_if(tracks.begin(), tracks.end(),
                                [](const config::AnimationTrack& t) {
                                    return t.target == "/camera/position" || t.target == "/camera/target";
                                }),
                 tracks.end());
    recordedPosition_ = {"/camera/position", config::Interpolation::Linear, {}};
    recordedTarget_ = {"/camera/target", config::Interpolation::Linear, {}};
    recording_ = true;
    playing_ = false;
    recordStart_ = std::chrono::steady_clock::now();
    recordCameraKey();
    message_ = "recording the camera";
}

// A key per frame in which the camera moved (and the first), at the wall-clock time since
// the recording started; times strictly increase, as the config requires.
void Viewer::recordCameraKey()
{
    const scene::Camera& c = session_->config().camera;
    const float t = std::chrono::duration<float>(std::chrono::steady_clock::now() - recordStart_).count();
    if (!recordedPosition_.keys.empty()) {
        const config::Keyframe& last = recordedPosition_.keys.back();
        const bool moved = last.value != std::vector<float>{c.position.x, c.position.y, c.position.z} ||
                           recordedTarget_.keys.back().value != std::vector<float>{c.target.x, c.target.y, c.target.z};
        if (!moved || !(t > last.timeS + 1e-3f)) return;
    }
    recordedPosition_.keys.push_back({t, {c.position.x, c.position.y, c.position.z}});
    recordedTarget_.keys.push_back({t, {c.target.x, c.target.y, c.target.z}});
}

void Viewer::stopRecording()
{
    if (!recording_) return;
    recording_ = false;
    // The camera where it stopped, held to the end.
    const float end = std::chrono::duration<float>(std::chrono::steady_clock::now() - recordStart_).count();
    const scene::Camera& c = session_->config().camera;
    if (end > recordedPosition_.keys.back().timeS + 1e-3f) {
        recordedPosition_.keys.push_back({end, {c.position.x, c.position.y, c.position.z}});
        recordedTarget_.keys.push_back({end, {c.target.x, c.target.y, c.target.z}});
    }
    config::RenderConfig& config = session_->config();
    config.animation.tracks.push_back(recordedPosition_);
    config.animation.tracks.push_back(recordedTarget_);
    session_->setCameraFollow(CameraFollow::Track);  // the path plays as recorded
    // `penumbra render` of the saved config plays the whole path.
    const float duration = session_->duration();
    config.frames = std::max(config.frames, config::framesToPlay(duration, config.animation.fps));
    message_ = fmt::format("recorded {} camera keys over {:.2f} s ({} frames at {} fps)", recordedPosition_.keys.size(), end,
                           config.frames, config.animation.fps);
    spdlog::info("{}", message_);
    session_->setTime(0.0f);
    session_->changed(Change::View);
}

void Viewer::afterRender()
{
    errorsDirty_ = true;  // A changed: its error against B is computed again
    history_.add(session_->lastTimings());
    // A slow frame is kept as shown: while the next one draws, the renderer's own images
    // are the frame in flight's (drawBusyFrame shows this copy). A fast one costs no copy.
    lastComplete_.reset();
    if (session_->lastFrameSeconds() >= kKeepFrameS) {
        const frame::FrameRenderer& r = session_->renderer();
        lastCompleteUpload_->set(r.width(), r.height(), r.readColor());
        lastComplete_ = {&r, session_->framesRendered()};
    }
    shownValues_.reset();
    if (!session_->shownImage().empty()) {
        shownValues_ = session_->renderer().readImage(session_->shownImage());
        debugClasses_ = imageClasses(*shownValues_);
        if (!debugMappingChosen_) {
            mapping_ = debugClasses_.empty() ? metrics::DebugMapping::Linear : metrics::DebugMapping::FalseColor;
            debugMappingChosen_ = true;  // the user's choice from now on, until another image is shown
        }
        if (autoRange_) range_ = metrics::finiteRange(*shownValues_, mapping_);
        debugUpload_->set(shownValues_->width, shownValues_->height, metrics::debugImageRgba(*shownValues_, mapping_, range_));
    }
}

void Viewer::resetDebugView()
{
    debugZoom_ = 1.0;
    debugPan_ = {0.0, 0.0};
    autoRange_ = true;
    debugMappingChosen_ = false;
}

// A classification (vssm's classes, a mask): one channel of at most kMaxClasses distinct
// finite values, each with its pixel count, ascending; empty for any other image.
std::vector<std::pair<float, uint64_t>> Viewer::imageClasses(const metrics::DebugImageValues& image)
{
    constexpr size_t kMaxClasses = 8;
    std::map<float, uint64_t> counts;
    if (image.channels != 1) return {};
    for (const float v : image.values) {
        if (!std::isfinite(v)) continue;
        ++counts[v];
        if (counts.size() > kMaxClasses) return {};
    }
    if (counts.size() < 2) return {};
    return {counts.begin(), counts.end()};
}

// The render size follows the view (the window less the panel) unless fixed; a change
// builds a renderer of the new size.
void Viewer::fitRenderSize()
{
    int fbw = 0, fbh = 0, ww = 0, wh = 0;
    glfwGetFramebufferSize(window_, &fbw, &fbh);
    glfwGetWindowSize(window_, &ww, &wh);
    if (fbw <= 0 || fbh <= 0 || ww <= 0) {
        viewRect_ = {};
        return;
    }
    const float fbScale = float(fbw) / float(ww);
    const int panel = showUi_ ? int(std::lround(panelWidth_ * uiScale_ * fbScale)) : 0;
    const uint32_t viewW = uint32_t(std::max(fbw - panel, 1)), viewH = uint32_t(fbh);
    config::RenderConfig& c = session_->config();
    uint32_t w = viewW, h = viewH;
    if (fixedSize_) std::tie(w, h) = *fixedSize_;
    if (w != c.width || h != c.height) {
        c.width = w;
        c.height = h;
        session_->changed(Change::Renderer);
    }
    // The frame fitted into the view, aspect kept, centred.
    const float scale = std::min(float(viewW) / float(w), float(viewH) / float(h));
    const uint32_t shownW = std::max(1u, uint32_t(std::lround(float(w) * scale)));
    const uint32_t shownH = std::max(1u, uint32_t(std::lround(float(h) * scale)));
    viewRect_.offset = {panel + int32_t(viewW - shownW) / 2, int32_t(viewH - shownH) / 2};
    viewRect_.extent = {shownW, shownH};
    viewArea_ = {{panel, 0}, {viewW, viewH}};
}

std::vector<ViewBlit> Viewer::viewBlits() const
{
    if (!session_->isOpen() || session_->framesRendered() == 0 || viewRect_.extent.width == 0) return {};
    const frame::FrameRenderer& r = session_->renderer();
    const ViewBlit a{&r.executor().image("color"), r.executor().finalLayout("color"), viewRect_};
    // B's modes show B only when it is of the view A shows; until then, A.
    if (compareOn_ && bCurrent() && viewMode_ != ViewMode::A) {
        if (viewMode_ == ViewMode::B) return {{&bUpload_->image(), UploadedImage::kLayout, viewRect_}};
        if (viewMode_ == ViewMode::Difference && !differenceUpload_->empty()) {
            return {{&differenceUpload_->image(), UploadedImage::kLayout, viewRect_}};
        }
        if (viewMode_ == ViewMode::Split) {
            // A left of the split, B right of it, each the matching part of its image.
            const uint32_t w = r.width(), h = r.height();
            const uint32_t cut = std::clamp(uint32_t(std::lround(splitAt_ * float(w))), 1u, w - 1);
            const uint32_t cutTarget = uint32_t(std::lround(float(cut) / float(w) * float(viewRect_.extent.width)));
            ViewBlit left = a, right{&bUpload_->image(), UploadedImage::kLayout, viewRect_};
            left.source = {{0, 0}, {cut, h}};
            left.target.extent.width = cutTarget;
            right.source = {{int32_t(cut), 0}, {w - cut, h}};
            right.target.offset.x += int32_t(cutTarget);
            right.target.extent.width = viewRect_.extent.width - cutTarget;
            return {left, right};
        }
    }
    if (!session_->shownImage().empty() && !debugUpload_->empty()) {
        const VkRect2D& whole = debugUpload_->image().desc().width ? VkRect2D{{0, 0}, {debugUpload_->image().desc().width,
                                                                                   debugUpload_->image().desc().height}}
                                                                    : VkRect2D{};
        ViewBlit blit{&debugUpload_->image(), UploadedImage::kLayout, {}, whole};
        if (debugImageBlit(whole.extent, blit.target, blit.source)) return {blit};
        return {};
    }
    return {a};
}

// A debug image in the view: its own aspect, scaled to fit at zoom 1, zoomed about the
// view's centre and panned; only its part inside the view is copied (target and source
// cut alike). False when none of it is in the view.
bool Viewer::debugImageBlit(VkExtent2D image, VkRect2D& target, VkRect2D& source) const
{
    if (image.width == 0 || image.height == 0 || viewArea_.extent.width == 0) return false;
    const double fit = std::min(double(viewArea_.extent.width) / image.width, double(viewArea_.extent.height) / image.height);
    const double scale = fit * debugZoom_;  // window pixels per image texel
    const double x0 = viewArea_.offset.x + 0.5 * viewArea_.extent.width - 0.5 * image.width * scale + debugPan_.x;
    const double y0 = viewArea_.offset.y + 0.5 * viewArea_.extent.height - 0.5 * image.height * scale + debugPan_.y;
    // The visible texels: whole texels, so that the copy's scale is the view's.
    const double tx0 = std::max(0.0, std::floor((viewArea_.offset.x - x0) / scale));
    const double ty0 = std::max(0.0, std::floor((viewArea_.offset.y - y0) / scale));
    const double tx1 = std::min(double(image.width), std::ceil((viewArea_.offset.x + viewArea_.extent.width - x0) / scale));
    const double ty1 = std::min(double(image.height), std::ceil((viewArea_.offset.y + viewArea_.extent.height - y0) / scale));
    if (!(tx1 > tx0 && ty1 > ty0)) return false;
    // Window pixels of those texels, cut to the view (a texel cut at the edge is drawn whole
    // inside the cut: at most one texel's shift at high zoom, where texels are large).
    const auto clampX = [&](double x) { return std::clamp(x, double(viewArea_.offset.x), double(viewArea_.offset.x + int32_t(viewArea_.extent.width))); };
    const auto clampY = [&](double y) { return std::clamp(y, double(viewArea_.offset.y), double(viewArea_.offset.y + int32_t(viewArea_.extent.height))); };
    const int32_t wx0 = int32_t(std::lround(clampX(x0 + tx0 * scale))), wx1 = int32_t(std::lround(clampX(x0 + tx1 * scale)));
    const int32_t wy0 = int32_t(std::lround(clampY(y0 + ty0 * scale))), wy1 = int32_t(std::lround(clampY(y0 + ty1 * scale)));
    if (wx1 <= wx0 || wy1 <= wy0) return false;
    target = {{wx0, wy0}, {uint32_t(wx1 - wx0), uint32_t(wy1 - wy0)}};
    source = {{int32_t(tx0), int32_t(ty0)}, {uint32_t(tx1 - tx0), uint32_t(ty1 - ty0)}};
    return true;
}

bool Viewer::bCurrent() const { return bResult_ && bResult_->viewKey == lastViewKey_ && !lastViewKey_.empty(); }

void Viewer::startComparison(const std::string& technique)
{
    if (technique != config::kNoShadowTechnique) session_->plugins().load(technique);  // throws PluginError naming it
    compareOn_ = true;
    bShadows_.assign(session_->config().lights.size(), {});
    for (config::ShadowSettings& b : bShadows_) {
        b.technique = technique;
        b.required = true;
        // The reference's 256 rays a pixel take a minute at 1280 x 720 on a CPU: 16 for a
        // first look (raise it in the panel).
        if (technique == "reference") b.setParam("samples", 16, "viewer: B reference.samples");
    }
    if (!comparison_) comparison_ = std::make_unique<ComparisonWorker>(options_.context, session_->plugins().searchPath());
    comparison_->cancel();
    forgetB();
}

// B's last image, error and view: asked for again once the view rests.
void Viewer::forgetB()
{
    bResult_.reset();
    bError_.clear();
    requestedKey_.clear();
    lastViewKey_.clear();
}

void Viewer::updateComparison()
{
    if (!compareOn_ || !comparison_ || session_->framesRendered() == 0) return;
    const auto now = std::chrono::steady_clock::now();
    if (bShadows_.size() != session_->shownConfig().lights.size()) {
        startComparison(bShadows_.empty() ? "reference" : bShadows_.front().technique);  // lights added or removed
    }
    const std::string key = viewKey(session_->shownView(), session_->time());
    if (key != lastViewKey_) {
        lastViewKey_ = key;
        stillSince_ = now;
        bError_.clear();
    }
    if (std::optional<ComparisonResult> r = comparison_->take()) {
        if (!r->error.empty()) {
            if (r->viewKey == key) bError_ = r->error;
            message_ = "B: " + r->error;
        } else {
            bResult_ = std::move(*r);
            bUpload_->set(bResult_->images.width, bResult_->images.height, bResult_->images.color);
            errorsDirty_ = true;
            spdlog::info("B drawn in {:.2f} s", bResult_->seconds);
        }
    }
    // Asked for once the view has rested: not for every step of a drag.
    if (!bCurrent() && requestedKey_ != key && now - stillSince_ >= std::chrono::milliseconds(400)) {
        comparison_->request({withShadows(session_->shownView(), bShadows_), session_->time(), key});
        requestedKey_ = key;
    }
    if (errorsDirty_ && bCurrent()) {
        const frame::FrameRenderer& r = session_->renderer();
        aVisibility_.clear();
        for (size_t l = 0; l < r.lightCount(); ++l) aVisibility_.push_back(r.readVisibility(l));
        stackErrors_ = compareStacks(aVisibility_, bResult_->images, session_->shownConfig().lights);
        updateDifferenceImage();
        errorsDirty_ = false;
    }
}

// |V_A - V_B| of one light, in false colour over [0, scale]; pixels not compared 0.
void Viewer::updateDifferenceImage()
{
    if (!bCurrent() || aVisibility_.empty()) return;
    const app::FrameImages& b = bResult_->images;
    const size_t l = size_t(std::clamp(differenceLight_, 0, int(aVisibility_.size()) - 1));
    const metrics::PixelMask mask = app::reachMask(session_->shownConfig().lights.at(l).light, b.width, b.height, b.positions);
    metrics::DebugImageValues diff;
    diff.width = b.width;
    diff.height = b.height;
    diff.values.resize(size_t(diff.width) * diff.height);
    for (size_t i = 0; i < diff.values.size(); ++i) {
        diff.values[i] = mask.covered[i] ? std::abs(aVisibility_[l][i] - b.visibility[l][i]) : 0.0f;
    }
    differenceRgba_ = metrics::debugImageRgba(diff, metrics::DebugMapping::FalseColor, {0.0, double(differenceScale_)});
    differenceUpload_->set(diff.width, diff.height, differenceRgba_);
}

// Keys are GLFW key codes: Dear ImGui 1.86 (Debian 12) indexes io.KeysDown by the backend's codes.
void Viewer::handleInput()
{
    const ImGuiIO& io = ImGui::GetIO();
    if (!io.WantCaptureKeyboard) {
        if (ImGui::IsKeyPressed(GLFW_KEY_F1)) showUi_ = !showUi_;
        if (ImGui::IsKeyPressed(GLFW_KEY_R) && !ImGui::IsMouseDown(ImGuiMouseButton_Right)) moveCamera(homeCamera_);
    }
    if (io.WantCaptureMouse && !ImGui::IsMouseDown(ImGuiMouseButton_Right)) return;
    const ImVec2 mouse = io.MousePos;
    const float fbScale = io.DisplayFramebufferScale.x > 0.0f ? io.DisplayFramebufferScale.x : 1.0f;
    const bool inView = mouse.x * fbScale >= float(viewRect_.offset.x) &&
                        mouse.x * fbScale < float(viewRect_.offset.x + int32_t(viewRect_.extent.width)) &&
                        mouse.y * fbScale >= float(viewRect_.offset.y) &&
                        mouse.y * fbScale < float(viewRect_.offset.y + int32_t(viewRect_.extent.height));
    const ImVec2 d = io.MouseDelta;
    if (!session_->shownImage().empty() && shownValues_ && !(compareOn_ && bCurrent() && viewMode_ != ViewMode::A)) {
        // A debug image: the wheel zooms about the cursor, a drag pans; the camera stays.
        if (ImGui::IsMouseDown(ImGuiMouseButton_Left)) debugPan_ += glm::dvec2(d.x, d.y) * double(fbScale);
        if (inView && io.MouseWheel != 0.0f) {
            const double factor = std::pow(1.15, double(io.MouseWheel));
            const double zoom = std::clamp(debugZoom_ * factor, 0.05, 512.0);
            // The texel under the cursor stays under it.
            const glm::dvec2 centre(viewArea_.offset.x + 0.5 * viewArea_.extent.width, viewArea_.offset.y + 0.5 * viewArea_.extent.height);
            const glm::dvec2 cursor = glm::dvec2(mouse.x, mouse.y) * double(fbScale) - centre;
            debugPan_ = cursor - (cursor - debugPan_) * (zoom / debugZoom_);
            debugZoom_ = zoom;
        }
        return;
    }
    scene::Camera camera = session_->viewCamera();
    const scene::Camera before = camera;
    const float radius = sceneRadius();
    if (cameraMode_ == CameraMode::Orbit) {
        const bool panning = ImGui::IsMouseDown(ImGuiMouseButton_Middle) ||
                             (ImGui::IsMouseDown(ImGuiMouseButton_Left) && io.KeyShift);
        if (panning && (d.x != 0.0f || d.y != 0.0f)) {
            const float perPixel = 1.0f / float(std::max(viewRect_.extent.height, 1u));
            camera = pan(camera, -d.x * perPixel * fbScale, d.y * perPixel * fbScale);
        } else if (ImGui::IsMouseDown(ImGuiMouseButton_Left) && (d.x != 0.0f || d.y != 0.0f)) {
            camera = orbit(camera, -d.x * 0.3f, d.y * 0.3f);
        }
        if (inView && io.MouseWheel != 0.0f) camera = dolly(camera, std::pow(0.88f, io.MouseWheel), radius);
    } else {
        const bool looking = ImGui::IsMouseDown(ImGuiMouseButton_Left) || ImGui::IsMouseDown(ImGuiMouseButton_Right);
        float yaw = 0.0f, pitch = 0.0f;
        if (looking) {
            yaw = -d.x * 0.2f;
            pitch = -d.y * 0.2f;
        }
        glm::vec3 move(0.0f);
        if (!io.WantCaptureKeyboard) {
            move.z += float(ImGui::IsKeyDown(GLFW_KEY_W)) - float(ImGui::IsKeyDown(GLFW_KEY_S));
            move.x += float(ImGui::IsKeyDown(GLFW_KEY_D)) - float(ImGui::IsKeyDown(GLFW_KEY_A));
            move.y += float(ImGui::IsKeyDown(GLFW_KEY_E)) - float(ImGui::IsKeyDown(GLFW_KEY_Q));
        }
        if (inView && io.MouseWheel != 0.0f) flySpeedExponent_ = std::clamp(flySpeedExponent_ + io.MouseWheel * 0.25f, -20.0f, 20.0f);
        move *= flySpeed(radius, flySpeedExponent_) * io.DeltaTime;
        if (yaw != 0.0f || pitch != 0.0f || move != glm::vec3(0.0f)) {
            camera = fly(camera, yaw, pitch, move, cameraMode_ == CameraMode::FirstPerson);
        }
    }
    if (camera.position != before.position || camera.target != before.target) moveCamera(camera);
}

void Viewer::moveCamera(const scene::Camera& camera)
{
    if (session_->moveCamera(camera)) {
        message_ = "free camera: the camera tracks are no longer followed (Camera > follow track; they stay in the config)";
        spdlog::info("{}", message_);
    }
}

size_t Viewer::lightIndex(const std::string& nameOrIndex, const ScriptCommand& command) const
{
    const auto& lights = session_->config().lights;
    for (size_t i = 0; i < lights.size(); ++i) {
        if (lights[i].name == nameOrIndex || std::to_string(i) == nameOrIndex) return i;
    }
    std::string names;
    for (const auto& l : lights) names += (names.empty() ? "" : ", ") + l.name;
    throw Error(fmt::format("{}: {}: no light \"{}\"; the lights are {} (or their index)", command.where, command.words[0],
                            core::shortText(nameOrIndex), names));
}

std::vector<uint8_t> Viewer::viewPixels(uint32_t& width, uint32_t& height)
{
    // What the view shows: B or the difference in those compare modes, else the debug
    // image shown, else the frame.
    if (compareOn_ && bCurrent() && viewMode_ == ViewMode::B) {
        width = bResult_->images.width;
        height = bResult_->images.height;
        return bResult_->images.color;
    }
    if (compareOn_ && bCurrent() && viewMode_ == ViewMode::Difference && !differenceRgba_.empty()) {
        width = bResult_->images.width;
        height = bResult_->images.height;
        return differenceRgba_;
    }
    if (!session_->shownImage().empty() && shownValues_) {
        width = shownValues_->width;
        height = shownValues_->height;
        return metrics::debugImageRgba(*shownValues_, mapping_, range_);
    }
    width = session_->renderer().width();
    height = session_->renderer().height();
    return session_->renderer().readColor();
}

void Viewer::writeScreenshot(const fs::path& file, bool window)
{
    io::imageFormatFor(file);  // a name that is no image's fails before the frame is drawn
    session_->renderIfChanged(false);
    if (window) {
        // The window as composed, panels included: one more shown frame, read back.
        // Drawn before Dear ImGui's frame begins: a long frame draws frames of its own.
        fitRenderSize();
        if (session_->renderIfChanged(false)) afterRender();
        ImGui_ImplVulkan_NewFrame();
        ImGui_ImplGlfw_NewFrame();
        ImGui::NewFrame();
        if (showUi_) drawPanels();
        ImGui::Render();
        std::vector<uint8_t> pixels;
        presenter_->present(viewBlits(), ImGui::GetDrawData(), true, kBackground, &pixels);
        if (pixels.empty()) throw Error(fmt::format("{}: the window's images cannot be read back on this device", file.string()));
        io::writeImage(file, presenter_->extent().width, presenter_->extent().height, pixels);
    } else {
        uint32_t w = 0, h = 0;
        const std::vector<uint8_t> pixels = viewPixels(w, h);
        io::writeImage(file, w, h, pixels);
    }
    message_ = fmt::format("wrote {}", file.string());
    spdlog::info("{}", message_);
}

// Runs script commands until one asks for frames (`frames N`, or the loop's own frame
// after each command). Returns false after `quit`.
bool Viewer::runScriptUntilFrame()
{
    if (framesToRun_ > 0) return true;
    if (waitUntil_) {
        if (!waitUntil_()) {
            if (std::chrono::steady_clock::now() < waitDeadline_) return true;
            spdlog::error("{}: not so within 120 s{}", waitWhat_,
                          session_->lastError().empty() ? "" : fmt::format(" (the viewer shows: {})", session_->lastError()));
            exitCode_ = 1;
            quit_ = true;
            return false;
        }
        waitUntil_ = nullptr;
    }
    if (waitCompare_) {
        if (!bError_.empty()) {
            spdlog::error("wait-compare: B could not be drawn: {}", bError_);
            exitCode_ = 1;
            quit_ = true;
            return false;
        }
        if (!(bCurrent() && !errorsDirty_)) {
            if (std::chrono::steady_clock::now() < waitCompareDeadline_) return true;
            spdlog::error("wait-compare: B was not drawn within 600 s");
            exitCode_ = 1;
            quit_ = true;
            return false;
        }
        waitCompare_ = false;
    }
    while (scriptNext_ < options_.script.size()) {
        const ScriptCommand& command = options_.script[scriptNext_++];
        panelsDirty_ = true;  // the panels show what the command changed
        try {
            runCommand(command);
        } catch (const std::exception& e) {
            // A script is a test or a batch job: the first failure ends it, with where.
            const std::string what = e.what();
            spdlog::error("{}", what.rfind(command.where, 0) == 0 ? what : fmt::format("{}: {}: {}", command.where, command.words[0], what));
            exitCode_ = 1;
            quit_ = true;
            return false;
        }
        if (quit_) return false;
        if (framesToRun_ > 0 || waitUntil_ || waitCompare_) return true;
    }
    return true;
}

void Viewer::runCommand(const ScriptCommand& command)
{
    const std::string& verb = command.words[0];
    config::RenderConfig& c = session_->config();
    if (verb == "quit") {
        expectWords(command, 1, "quit");
        quit_ = true;
    } else if (verb == "frames") {
        expectWords(command, 2, "frames N");
        framesToRun_ = parseInt(command.words[1], command, 1, 100000);
    } else if (verb == "open") {
        expectWords(command, 2, "open FILE");
        session_->open(command.words[1]);
        homeCamera_ = session_->config().camera;
        history_ = {};
    } else if (verb == "size") {
        expectWords(command, 3, "size WIDTH HEIGHT");
        fixedSize_ = std::make_pair(uint32_t(parseInt(command.words[1], command, 1, 16384)),
                                    uint32_t(parseInt(command.words[2], command, 1, 16384)));
        fitRenderSize();
    } else if (verb == "window") {
        expectWords(command, 3, "window WIDTH HEIGHT");
        glfwSetWindowSize(window_, parseInt(command.words[1], command, 64, 16384), parseInt(command.words[2], command, 64, 16384));
    } else if (verb == "camera") {
        expectWords(command, 7, "camera PX PY PZ TX TY TZ");
        scene::Camera camera = session_->viewCamera();
        camera.position = parseVec3(command, 1);
        camera.target = parseVec3(command, 4);
        const glm::vec3 view = camera.target - camera.position;
        if (!(glm::length(view) > 0.0f)) {
            throw Error(fmt::format("{}: camera: the target must differ from the position", command.where));
        }
        // As the config reader requires: a view along the up axis has no image orientation.
        if (glm::length(glm::cross(glm::normalize(view), glm::normalize(camera.up))) < 1e-4f) {
            throw Error(fmt::format("{}: camera: the view must not be parallel to the up axis ({}, {}, {})", command.where,
                                    camera.up.x, camera.up.y, camera.up.z));
        }
        moveCamera(camera);
    } else if (verb == "orbit") {
        expectWords(command, 3, "orbit YAW_DEG PITCH_DEG");
        moveCamera(orbit(session_->viewCamera(), parseFloat(command.words[1], command), parseFloat(command.words[2], command)));
    } else if (verb == "dolly") {
        expectWords(command, 2, "dolly FACTOR");
        const float factor = parseFloat(command.words[1], command);
        if (!(factor > 0.0f)) throw Error(fmt::format("{}: dolly: the factor must be > 0", command.where));
        moveCamera(dolly(session_->viewCamera(), factor, sceneRadius()));
    } else if (verb == "camera-track") {
        expectWords(command, 2, "camera-track follow|free");
        if (!hasCameraTrack(c.animation)) {
            throw Error(fmt::format("{}: camera-track: the config has no camera track (/camera/...) to follow", command.where));
        }
        if (command.words[1] != "follow" && command.words[1] != "free") {
            throw Error(fmt::format("{}: camera-track: expected follow or free, got \"{}\"", command.where,
                                    core::shortText(command.words[1])));
        }
        session_->setCameraFollow(command.words[1] == "follow" ? CameraFollow::Track : CameraFollow::Free);
    } else if (verb == "print-camera") {
        // The pose drawn last and the one the camera panel showed: a test holds them equal.
        expectWords(command, 1, "print-camera");
        session_->renderIfChanged(false);
        const scene::Camera& d = session_->drawnCamera();
        fmt::print("camera {} drawn {:.6g} {:.6g} {:.6g} {:.6g} {:.6g} {:.6g} panel {:.6g} {:.6g} {:.6g} {:.6g} {:.6g} {:.6g}\n",
                   session_->followsCameraTrack() ? "follow" : "free", d.position.x, d.position.y, d.position.z, d.target.x,
                   d.target.y, d.target.z, panelCamera_.position.x, panelCamera_.position.y, panelCamera_.position.z,
                   panelCamera_.target.x, panelCamera_.target.y, panelCamera_.target.z);
        std::fflush(stdout);
    } else if (verb == "set") {
        // As `penumbra render --set`: every light that uses the technique.
        expectWords(command, 2, "set TECHNIQUE.PARAM=VALUE");
        const config::ParamOverride o = config::parseParamOverride(command.words[1]);
        bool used = false;
        for (size_t i = 0; i < c.lights.size(); ++i) {
            if (c.lights[i].shadow.technique != o.technique) continue;
            session_->setParam(i, o.param, o.value, fmt::format("{}: set {}.{}", command.where, o.technique, o.param));
            used = true;
        }
        if (!used) throw Error(fmt::format("{}: set: no light uses the technique \"{}\"", command.where, core::shortText(o.technique)));
    } else if (verb == "param") {
        expectWords(command, 4, "param LIGHT NAME VALUE");
        const size_t light = lightIndex(command.words[1], command);
        nlohmann::json value = nlohmann::json::parse(command.words[3], nullptr, false);
        if (value.is_discarded()) value = command.words[3];
        session_->setParam(light, command.words[2], value, fmt::format("{}: param {}", command.where, command.words[2]));
    } else if (verb == "technique") {
        expectWords(command, 3, "technique LIGHT NAME");
        session_->setTechnique(lightIndex(command.words[1], command), command.words[2]);
    } else if (verb == "culling") {
        expectWords(command, 2, "culling MODE");
        c.culling = config::parseCullingMode(command.words[1]);
        session_->changed(Change::Renderer);
    } else if (verb == "light") {
        // light LIGHT position|direction|target X Y Z, light LIGHT intensity V
        if (command.words.size() < 4) throw Error(fmt::format("{}: light: expected `light LIGHT FIELD VALUE...`", command.where));
        config::LightConfig& l = c.lights.at(lightIndex(command.words[1], command));
        const std::string& field = command.words[2];
        if (field == "intensity") {
            expectWords(command, 4, "light LIGHT intensity VALUE");
            const float v = parseFloat(command.words[3], command);
            if (v < 0.0f) throw Error(fmt::format("{}: light: the intensity must be >= 0", command.where));
            l.light.intensity = v;
        } else if (field == "position" || field == "direction" || field == "target") {
            expectWords(command, 6, "light LIGHT position|direction|target X Y Z");
            const glm::vec3 v = parseVec3(command, 3);
            if (field == "position") {
                l.light.position = v;
                if (l.target && glm::length(*l.target - v) > 0.0f) l.light.direction = glm::normalize(*l.target - v);
            } else {
                const glm::vec3 axis = field == "target" ? v - l.light.position : v;
                if (!(glm::length(axis) > 0.0f)) throw Error(fmt::format("{}: light: the {} gives no direction", command.where, field));
                l.light.direction = glm::normalize(axis);
                l.target = field == "target" ? std::optional<glm::vec3>(v) : std::nullopt;
            }
        } else {
            throw Error(fmt::format("{}: light: unknown field \"{}\"; expected position, direction, target or intensity",
                                    command.where, core::shortText(field)));
        }
        session_->changed(Change::View);
    } else if (verb == "show") {
        if (command.words.size() < 2 || command.words.size() > 3) throw Error(fmt::format("{}: show: expected `show IMAGE [linear|log|false-color]` or `show color`", command.where));
        // The image's own default mapping (afterRender: false colour for a classification,
        // else linear; automatic range), at zoom 1, unless the command names one.
        session_->showImage(command.words[1] == "color" ? std::string() : command.words[1]);
        resetDebugView();
        if (command.words.size() == 3) mapping_ = metrics::parseDebugMapping(command.words[2]);
        debugMappingChosen_ = command.words.size() == 3;
    } else if (verb == "continuous") {
        continuous_ = parseOnOff(command, "continuous on|off");
    } else if (verb == "vsync") {
        presenter_->setVsync(parseOnOff(command, "vsync on|off"));
    } else if (verb == "ui") {
        showUi_ = parseOnOff(command, "ui on|off");
    } else if (verb == "panel") {
        expectWords(command, 3, "panel NAME open|closed");
        static const std::set<std::string> names{"file",      "scene",   "camera",       "render", "lights",
                                                 "animation", "compare", "debug images", "timings"};
        const std::string name = panelKey(command.words[1]);
        if (!names.contains(name)) {
            throw Error(fmt::format("{}: panel \"{}\": expected one of file, scene, camera, render, lights, animation, "
                                    "compare, \"debug images\" or timings",
                                    command.where, core::shortText(command.words[1])));
        }
        if (command.words[2] != "open" && command.words[2] != "closed") {
            throw Error(fmt::format("{}: panel {} \"{}\": expected open or closed", command.where, name,
                                    core::shortText(command.words[2])));
        }
        panelOpen_[name] = command.words[2] == "open";
    } else if (verb == "panel-layer") {
        presenter_->setPanelLayer(parseOnOff(command, "panel-layer on|off"));
    } else if (verb == "screenshot") {
        expectWords(command, 2, "screenshot FILE.png|FILE.jpg");
        writeScreenshot(command.words[1], false);
    } else if (verb == "screenshot-window") {
        expectWords(command, 2, "screenshot-window FILE.png|FILE.jpg");
        writeScreenshot(command.words[1], true);
    } else if (verb == "save") {
        expectWords(command, 2, "save FILE.json");
        session_->renderIfChanged(false);
        session_->save(command.words[1]);
    } else if (verb == "compare") {
        expectWords(command, 2, "compare TECHNIQUE|off");
        if (command.words[1] == "off") {
            compareOn_ = false;
            if (comparison_) comparison_->cancel();
        } else {
            startComparison(command.words[1]);
        }
    } else if (verb == "compare-set") {
        expectWords(command, 2, "compare-set TECHNIQUE.PARAM=VALUE");
        const config::ParamOverride o = config::parseParamOverride(command.words[1]);
        bool used = false;
        for (config::ShadowSettings& b : bShadows_) {
            if (b.technique != o.technique) continue;
            config::ShadowSettings trial = b;
            trial.setParam(o.param, o.value, fmt::format("{}: compare-set {}.{}", command.where, o.technique, o.param));
            plugin::resolveParams(session_->plugins().load(trial.technique), trial);  // throws naming where
            b = std::move(trial);
            used = true;
        }
        if (!used) {
            throw Error(fmt::format("{}: compare-set: B uses no \"{}\" (compare TECHNIQUE first)", command.where,
                                    core::shortText(o.technique)));
        }
        bResult_.reset();
        requestedKey_.clear();
        if (comparison_) comparison_->cancel();
    } else if (verb == "compare-view") {
        expectWords(command, 2, "compare-view a|b|split|difference");
        const std::string& m = command.words[1];
        if (m == "a") viewMode_ = ViewMode::A;
        else if (m == "b") viewMode_ = ViewMode::B;
        else if (m == "split") viewMode_ = ViewMode::Split;
        else if (m == "difference") viewMode_ = ViewMode::Difference;
        else throw Error(fmt::format("{}: compare-view: \"{}\" is not a, b, split or difference", command.where, core::shortText(m)));
    } else if (verb == "inspect") {
        // The pixel inspector's text for a pixel of the frame, one `inspect` line per row.
        expectWords(command, 3, "inspect X Y");
        session_->renderIfChanged(false);
        const frame::FrameRenderer& r = session_->renderer();
        const std::string text = pixelReport(uint32_t(parseInt(command.words[1], command, 0, int(r.width()) - 1)),
                                             uint32_t(parseInt(command.words[2], command, 0, int(r.height()) - 1)));
        for (size_t at = 0; at <= text.size();) {
            const size_t end = std::min(text.find('\n', at), text.size());
            fmt::print("inspect {}\n", text.substr(at, end - at));
            at = end + 1;
        }
        std::fflush(stdout);
    } else if (verb == "cancel-after") {
        // A frame of A still drawing after SECONDS is cancelled (as its Cancel button does).
        expectWords(command, 2, "cancel-after SECONDS");
        const float seconds = parseFloat(command.words[1], command);
        if (seconds < 0.0f) throw Error(fmt::format("{}: cancel-after: the time must be >= 0", command.where));
        cancelAfterS_ = seconds;
    } else if (verb == "wait-compare") {
        expectWords(command, 1, "wait-compare");
        if (!compareOn_) throw Error(fmt::format("{}: wait-compare: no comparison (compare TECHNIQUE first)", command.where));
        waitCompare_ = true;
        waitCompareDeadline_ = std::chrono::steady_clock::now() + std::chrono::seconds(600);
    } else if (verb == "errors") {
        // The shown stack's error against B, per light, as the Compare panel shows it.
        expectWords(command, 1, "errors");
        if (!bCurrent()) throw Error(fmt::format("{}: errors: B is not drawn for this view (wait-compare first)", command.where));
        const auto& lights = session_->shownConfig().lights;
        for (size_t l = 0; l < stackErrors_.size(); ++l) {
            const metrics::VisibilityComparison& e = stackErrors_[l];
            fmt::print("error {} pixels {} rmse {:.6g} mae {:.6g} max {:.6g} above_0.05 {:.6g} umbra {:.6g} penumbra {:.6g} lit {:.6g} "
                       "ssim {:.6g}\n",
                       lights[l].name, e.all.pixels, e.all.rmse, e.all.mae, e.all.maxAbsError, e.all.percentAbove(0),
                       e.region(metrics::Region::Umbra).rmse, e.region(metrics::Region::Penumbra).rmse,
                       e.region(metrics::Region::Lit).rmse, e.ssim);
        }
        std::fflush(stdout);
    } else if (verb == "record") {
        expectWords(command, 2, "record start|stop");
        if (command.words[1] == "start") {
            startRecording();
        } else if (command.words[1] == "stop") {
            if (!recording_) throw Error(fmt::format("{}: record stop: not recording", command.where));
            stopRecording();
        } else {
            throw Error(fmt::format("{}: record: expected start or stop, got \"{}\"", command.where, core::shortText(command.words[1])));
        }
    } else if (verb == "time") {
        expectWords(command, 2, "time SECONDS");
        const float t = parseFloat(command.words[1], command);
        if (t < 0.0f || t > session_->duration()) {
            throw Error(fmt::format("{}: time: {} is outside the animation's [0, {}] s", command.where, t, session_->duration()));
        }
        session_->setTime(t);
    } else if (verb == "play") {
        playing_ = parseOnOff(command, "play on|off");
    } else if (verb == "wait-for" || verb == "wait-error" || verb == "wait-no-error") {
        // For tests that edit files while the viewer runs: frames go on until FILE exists,
        // or the viewer shows an error with TEXT, or none (hot reload polls the disk).
        if (verb == "wait-no-error") {
            expectWords(command, 1, "wait-no-error");
            waitUntil_ = [this] { return session_->lastError().empty(); };
        } else {
            expectWords(command, 2, verb == "wait-for" ? "wait-for FILE" : "wait-error TEXT");
            const std::string arg = command.words[1];
            if (verb == "wait-for") {
                waitUntil_ = [arg] {
                    std::error_code ec;
                    return fs::exists(arg, ec);
                };
            } else {
                waitUntil_ = [this, arg] { return session_->lastError().find(arg) != std::string::npos; };
            }
        }
        waitWhat_ = fmt::format("{}: {}", command.where, fmt::join(command.words, " "));
        waitDeadline_ = std::chrono::steady_clock::now() + std::chrono::seconds(120);
    } else if (verb == "expect-error") {
        expectWords(command, 2, "expect-error TEXT");
        session_->renderIfChanged(false);
        if (session_->lastError().find(command.words[1]) == std::string::npos) {
            throw Error(fmt::format("{}: expected an error with \"{}\", the viewer shows {}", command.where, core::shortText(command.words[1]),
                                    session_->lastError().empty() ? "none" : "\"" + session_->lastError() + "\""));
        }
    } else if (verb == "expect-no-error") {
        expectWords(command, 1, "expect-no-error");
        session_->renderIfChanged(false);
        if (!session_->lastError().empty()) throw Error(fmt::format("{}: the viewer shows an error: {}", command.where, session_->lastError()));
    } else if (verb == "save-visibility") {
        expectWords(command, 2, "save-visibility FILE.exr");
        session_->renderIfChanged(false);
        frame::FrameRenderer& r = session_->renderer();
        std::vector<std::vector<float>> visibility;
        for (size_t l = 0; l < r.lightCount(); ++l) visibility.push_back(r.readVisibility(l));
        app::writeVisibilityExr(command.words[1], r.width(), r.height(), session_->config().lights, visibility);
        spdlog::info("wrote {} (V of {} light(s))", command.words[1], visibility.size());
    } else if (verb == "widgets") {
        // The technique parameter widgets of the panels last drawn, one per line on stdout.
        expectWords(command, 1, "widgets");
        for (const std::string& w : drawnParamWidgets_) fmt::print("widget {}\n", w);
        std::fflush(stdout);
    } else if (verb == "timings") {
        // Prints the rolling medians, as the panel shows them.
        expectWords(command, 1, "timings");
        for (const std::string& pass : history_.order) {
            spdlog::info("timing {} gpu {:.3f} ms cpu {:.3f} ms", pass, TimingHistory::median(history_.gpuMs[pass]),
                         TimingHistory::median(history_.cpuMs[pass]));
        }
        spdlog::info("timing frame {:.3f} ms, sum of passes {:.3f} ms, viewer (panels + present) {:.3f} ms, last rebuild "
                     "(an edit to its first frame) {:.3f} ms",
                     TimingHistory::median(history_.frameMs), TimingHistory::median(history_.sumGpuMs),
                     TimingHistory::median(history_.viewerMs), session_->lastRebuildMs());
        const size_t built = size_t(std::count_if(history_.panelsCpuMs.begin(), history_.panelsCpuMs.end(),
                                                  [](float ms) { return ms > 0.0f; }));
        spdlog::info("timing shown frame {:.3f} ms (the loop's wall clock, median)", TimingHistory::median(history_.shownMs));
        spdlog::info("timing panels {:.3f} ms CPU + {:.3f} ms GPU a shown frame (means; built in {} of the last {} "
                     "frames, panel layer {}), {:.2f} % of the frame",
                     TimingHistory::mean(history_.panelsCpuMs), TimingHistory::mean(history_.panelsGpuMs), built,
                     history_.panelsCpuMs.size(), presenter_->panelLayer() ? "on" : "off", history_.panelsShare());
    } else {
        throw Error(fmt::format("{}: unknown command \"{}\"; expected open, size, window, camera, orbit, dolly, set, param, "
                                "camera-track, print-camera, technique, culling, light, show, continuous, vsync, ui, frames, screenshot, "
                                "screenshot-window, save, save-visibility, compare, compare-set, compare-view, wait-compare, cancel-after, inspect, errors, "
                                "wait-for, "
                                "wait-error, wait-no-error, expect-error, expect-no-error, record, time, play, widgets, timings, "
                                "panel, panel-layer or quit",
                                command.where, core::shortText(verb)));
    }
}

int runViewer(const ViewerOptions& options)
{
    glfwSetErrorCallback(onGlfwError);
    if (!glfwInit()) {
        spdlog::error("cannot open a window: {}{}", glfwErrorText.empty() ? "GLFW failed to initialise" : glfwErrorText,
                      std::getenv("DISPLAY") ? "" : " (no DISPLAY: run under a desktop session or xvfb-run)");
        return 1;
    }
    int code = 1;
    try {
        if (!glfwVulkanSupported()) {
            throw GpuError(fmt::format("no Vulkan loader with window-system support was found{}",
                                       glfwErrorText.empty() ? "" : ": " + glfwErrorText));
        }
        Viewer viewer(options);
        code = viewer.run();
    } catch (const std::exception& e) {
        spdlog::error("{}", e.what());
        code = 1;
    }
    glfwTerminate();
    return code;
}

} // namespace penumbra::viewer
