#include "Viewer.h"

#include "penumbra/core/Error.h"
#include "penumbra/io/Png.h"
#include "penumbra/metrics/Images.h"

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

Viewer::Viewer(const ViewerOptions& options)
    : options_(options), comparison_([this](const std::vector<fs::path>& pluginSearchPath) {
          return std::make_unique<ComparisonWorker>(options_.context, pluginSearchPath);
      })
{
    gpu::ContextOptions contextOptions = options.context;
    contextOptions.presentation = glfwPresentation();
    context_ = std::make_unique<gpu::Context>(contextOptions);
    spdlog::info("device: {} ({})", context_->deviceInfo().name, context_->deviceInfo().type);
    plugins_ = std::make_unique<plugin::PluginRegistry>();
    pluginReloader_ = std::make_unique<PluginReloader>(plugin::defaultPluginSearchPath());
    session_ = std::make_unique<Session>(*context_, *plugins_);
    session_->setVisibilityWanted([this] { return wantsVisibility(); });
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
    comparison_.stop();  // B's frame in flight stops at its next row: its worker joins soon after
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
    const uint32_t bMessages = comparison_.validationMessages();
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
        else inspecting_ = false;  // no pixel inspector without the panels
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
                if (comparison_.usePlugins(reloadedPlugins_.back()->searchPath())) {
                    spdlog::info("B: a new worker with the plugins of {}", reloadedPlugins_.back()->searchPath().front().string());
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
        comparison_.stop();
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
    comparison_.aChanged();
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
    if (comparison_.replacesA()) {
        if (comparison_.view() == CompareView::B) return {{&bUpload_->image(), UploadedImage::kLayout, viewRect_}};
        if (comparison_.view() == CompareView::Difference && !differenceUpload_->empty()) {
            return {{&differenceUpload_->image(), UploadedImage::kLayout, viewRect_}};
        }
        if (comparison_.view() == CompareView::Split) {
            // A left of the split, B right of it, each the matching part of its image.
            const uint32_t w = r.width(), h = r.height();
            const uint32_t cut = std::clamp(uint32_t(std::lround(comparison_.splitAt() * float(w))), 1u, w - 1);
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

bool Viewer::wantsVisibility() const
{
    return inspecting_ || visibilityPinned_ || comparison_.on() || !session_->shownImage().empty();
}

void Viewer::drawWithVisibility()
{
    visibilityPinned_ = true;
    struct Unpin {
        bool& pinned;
        ~Unpin() { pinned = false; }
    } unpin{visibilityPinned_};
    session_->renderIfChanged(false);
}

void Viewer::startComparison(const std::string& technique)
{
    if (technique != config::kNoShadowTechnique) session_->plugins().load(technique);  // throws PluginError naming it
    comparison_.start(technique, session_->config().lights.size(), session_->plugins().searchPath());
}

void Viewer::updateComparison()
{
    // The first frame after B starts may have kept no image of V: the next one does.
    if (session_->framesRendered() == 0 || !session_->visibilityKept()) return;
    const std::string notice = comparison_.update(session_->shownView(), session_->time(), std::chrono::steady_clock::now(), [this] {
        const frame::FrameRenderer& r = session_->renderer();
        std::vector<std::vector<float>> visibility;
        for (size_t l = 0; l < r.lightCount(); ++l) visibility.push_back(r.readVisibility(l));
        return visibility;
    });
    if (!notice.empty()) message_ = notice;
    uploadComparisonImages();
}

// B's image and the difference image into the view's images, when they changed.
void Viewer::uploadComparisonImages()
{
    if (const ComparisonResult* b = comparison_.result(); b && bUploaded_ != comparison_.bImageVersion()) {
        bUpload_->set(b->images.width, b->images.height, b->images.color);
        bUploaded_ = comparison_.bImageVersion();
    }
    if (const ComparisonResult* b = comparison_.result(); b && differenceUploaded_ != comparison_.differenceVersion()) {
        differenceUpload_->set(b->images.width, b->images.height, comparison_.differenceRgba());
        differenceUploaded_ = comparison_.differenceVersion();
    }
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
    if (!session_->shownImage().empty() && shownValues_ && !comparison_.replacesA()) {
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

std::vector<uint8_t> Viewer::viewPixels(uint32_t& width, uint32_t& height)
{
    // What the view shows: B or the difference in those compare modes, else the debug
    // image shown, else the frame.
    if (comparison_.shows(CompareView::B)) {
        width = comparison_.result()->images.width;
        height = comparison_.result()->images.height;
        return comparison_.result()->images.color;
    }
    if (comparison_.shows(CompareView::Difference) && !comparison_.differenceRgba().empty()) {
        width = comparison_.result()->images.width;
        height = comparison_.result()->images.height;
        return comparison_.differenceRgba();
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
        else inspecting_ = false;  // no pixel inspector without the panels
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
        if (!comparison_.bError().empty()) {
            spdlog::error("wait-compare: B could not be drawn: {}", comparison_.bError());
            exitCode_ = 1;
            quit_ = true;
            return false;
        }
        if (!comparison_.ready()) {
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
            commands().run(*this, command);
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

int runViewer(const ViewerOptions& options)
{
    // Every command's verb and argument count before the window opens: a typo in a long
    // script costs no start, and shows without a display too.
    try {
        for (const ScriptCommand& command : options.script) Viewer::commands().list().check(command);
    } catch (const Error& e) {
        spdlog::error("{}", e.what());
        return 1;
    }
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
