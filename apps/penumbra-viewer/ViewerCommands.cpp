// The viewer's script commands (`--script`, `--exec`): one table of verb, argument forms,
// help and handler (CommandTable.h). Its order is docs/viewer.md's, where
// `penumbra-viewer --list-commands` prints it.
#include "Viewer.h"

#include "VisibilityExr.h"  // apps/penumbra: the CLI's float V output

#include "penumbra/config/Overrides.h"
#include "penumbra/core/Error.h"
#include "penumbra/core/ShortText.h"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <set>

namespace fs = std::filesystem;

namespace penumbra::viewer {
namespace {

float parseFloat(const ScriptCommand& command, size_t word)
{
    const std::string& text = command.words.at(word);
    float value = 0.0f;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (ec != std::errc() || end != text.data() + text.size() || !std::isfinite(value)) {
        throwCommandError(command, fmt::format("expected a finite number, got \"{}\"", core::shortText(text)));
    }
    return value;
}

int parseInt(const ScriptCommand& command, size_t word, int lo, int hi)
{
    const std::string& text = command.words.at(word);
    int value = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (ec != std::errc() || end != text.data() + text.size() || value < lo || value > hi) {
        throwCommandError(command, fmt::format("expected a whole number in [{}, {}], got \"{}\"", lo, hi, core::shortText(text)));
    }
    return value;
}

glm::vec3 parseVec3(const ScriptCommand& command, size_t first)
{
    return {parseFloat(command, first), parseFloat(command, first + 1), parseFloat(command, first + 2)};
}

// A word that must be one of `choices`: anything else is an error, never the last choice.
const std::string& parseChoice(const ScriptCommand& command, size_t word, std::initializer_list<std::string_view> choices)
{
    const std::string& text = command.words.at(word);
    if (std::find(choices.begin(), choices.end(), text) == choices.end()) {
        std::vector<std::string_view> all(choices);
        const std::string_view last = all.back();
        all.pop_back();
        throwCommandError(command, fmt::format("expected {} or {}, got \"{}\"", fmt::join(all, ", "), last, core::shortText(text)));
    }
    return text;
}

bool parseOnOff(const ScriptCommand& command) { return parseChoice(command, 1, {"on", "off"}) == "on"; }

// Prints `text` with `prefix` before each of its lines, for a test to read.
void printLines(const std::string& prefix, const std::string& text)
{
    for (size_t at = 0; at <= text.size();) {
        const size_t end = std::min(text.find('\n', at), text.size());
        fmt::print("{} {}\n", prefix, text.substr(at, end - at));
        at = end + 1;
    }
    std::fflush(stdout);
}

} // namespace

size_t Viewer::lightIndex(const std::string& nameOrIndex, const ScriptCommand& command) const
{
    const auto& lights = session_->config().lights;
    for (size_t i = 0; i < lights.size(); ++i) {
        if (lights[i].name == nameOrIndex || std::to_string(i) == nameOrIndex) return i;
    }
    std::vector<std::string> names;
    for (const auto& l : lights) names.push_back(l.name);
    throwCommandError(command, fmt::format("no light \"{}\"; the lights are {} (or their index)", core::shortText(nameOrIndex),
                                           fmt::join(names, ", ")));
}

void Viewer::waitUntil(const ScriptCommand& command, std::function<bool()> condition)
{
    waitUntil_ = std::move(condition);
    waitWhat_ = fmt::format("{}: {}", command.where, fmt::join(command.words, " "));
    waitDeadline_ = std::chrono::steady_clock::now() + std::chrono::seconds(120);
}

void Viewer::printTimings()
{
    for (const std::string& pass : history_.order) {
        spdlog::info("timing {} gpu {:.3f} ms cpu {:.3f} ms", pass, TimingHistory::median(history_.gpuMs[pass]),
                     TimingHistory::median(history_.cpuMs[pass]));
    }
    spdlog::info("timing frame {:.3f} ms, sum of passes {:.3f} ms, viewer (panels + present) {:.3f} ms, last rebuild "
                 "(an edit to its first frame) {:.3f} ms",
                 TimingHistory::median(history_.frameMs), TimingHistory::median(history_.sumGpuMs),
                 TimingHistory::median(history_.viewerMs), session_->lastRebuildMs());
    const size_t built = size_t(std::count_if(history_.panelsCpuMs.begin(), history_.panelsCpuMs.end(), [](float ms) { return ms > 0.0f; }));
    spdlog::info("timing shown frame {:.3f} ms (the loop's wall clock, median)", TimingHistory::median(history_.shownMs));
    spdlog::info("timing panels {:.3f} ms CPU + {:.3f} ms GPU a shown frame (means; built in {} of the last {} "
                 "frames, panel layer {}), {:.2f} % of the frame",
                 TimingHistory::mean(history_.panelsCpuMs), TimingHistory::mean(history_.panelsGpuMs), built,
                 history_.panelsCpuMs.size(), presenter_->panelLayer() ? "on" : "off", history_.panelsShare());
    if (session_->framesRendered() == 0) return;
    const frame::FrameRenderer& r = session_->renderer();
    for (size_t l = 0; l < r.lightCount() && l < session_->config().lights.size(); ++l) {
        spdlog::info("timing visibility {}: {}", session_->config().lights[l].name,
                     r.visibilityInShading(l) ? "evaluated in shading, no image" : "an image");
    }
}

const CommandTable<Viewer>& Viewer::commands()
{
    using C = const ScriptCommand&;
    static const CommandTable<Viewer> table{
        {{"open", {"FILE"}, "opens a config or glTF file"},
         [](Viewer& v, C c) {
             v.session_->open(c.words[1]);
             v.homeCamera_ = v.session_->config().camera;
             v.history_ = {};
         }},
        {{"size", {"W H"}, "fixes the render size (the frame is scaled into the view)"},
         [](Viewer& v, C c) {
             v.fixedSize_ = std::make_pair(uint32_t(parseInt(c, 1, 1, 16384)), uint32_t(parseInt(c, 2, 1, 16384)));
             v.fitRenderSize();
         }},
        {{"window", {"W H"}, "resizes the window"},
         [](Viewer& v, C c) { glfwSetWindowSize(v.window_, parseInt(c, 1, 64, 16384), parseInt(c, 2, 64, 16384)); }},
        {{"camera", {"PX PY PZ TX TY TZ"}, "places the camera (as `orbit` and `dolly`, it frees a followed track)"},
         [](Viewer& v, C c) {
             scene::Camera camera = v.session_->viewCamera();
             camera.position = parseVec3(c, 1);
             camera.target = parseVec3(c, 4);
             const glm::vec3 view = camera.target - camera.position;
             if (!(glm::length(view) > 0.0f)) throwCommandError(c, "the target must differ from the position");
             // As the config reader requires: a view along the up axis has no image orientation.
             if (glm::length(glm::cross(glm::normalize(view), glm::normalize(camera.up))) < 1e-4f) {
                 throwCommandError(c, fmt::format("the view must not be parallel to the up axis ({}, {}, {})", camera.up.x,
                                                  camera.up.y, camera.up.z));
             }
             v.moveCamera(camera);
         }},
        {{"camera-track", {"follow|free"},
          "follows the config's camera tracks, or frees the camera from the pose drawn (an error without camera tracks)"},
         [](Viewer& v, C c) {
             if (!hasCameraTrack(v.session_->config().animation)) {
                 throwCommandError(c, "the config has no camera track (/camera/...) to follow");
             }
             v.session_->setCameraFollow(parseChoice(c, 1, {"follow", "free"}) == "follow" ? CameraFollow::Track : CameraFollow::Free);
         }},
        {{"print-camera", {},
          "prints `camera follow|free drawn PX PY PZ TX TY TZ panel PX PY PZ TX TY TZ`: the pose drawn and the one the camera "
          "panel showed"},
         [](Viewer& v, C) {
             v.session_->renderIfChanged(false);
             const scene::Camera& d = v.session_->drawnCamera();
             const scene::Camera& p = v.panelCamera_;
             fmt::print("camera {} drawn {:.6g} {:.6g} {:.6g} {:.6g} {:.6g} {:.6g} panel {:.6g} {:.6g} {:.6g} {:.6g} {:.6g} {:.6g}\n",
                        v.session_->followsCameraTrack() ? "follow" : "free", d.position.x, d.position.y, d.position.z,
                        d.target.x, d.target.y, d.target.z, p.position.x, p.position.y, p.position.z, p.target.x, p.target.y,
                        p.target.z);
             std::fflush(stdout);
         }},
        {{"inspect", {"X Y"},
          "prints the pixel inspector's text for frame pixel (X, Y), one `inspect` line per row (with B's V and ΔV while B "
          "is of this view)"},
         [](Viewer& v, C c) {
             v.drawWithVisibility();
             const frame::FrameRenderer& r = v.session_->renderer();
             const uint32_t x = uint32_t(parseInt(c, 1, 0, int(r.width()) - 1));
             const uint32_t y = uint32_t(parseInt(c, 2, 0, int(r.height()) - 1));
             printLines("inspect", v.pixelReport(x, y));
         }},
        {{"cancel-after", {"SECONDS"}, "a frame of A still drawing after SECONDS is cancelled, as its Cancel button does"},
         [](Viewer& v, C c) {
             const float seconds = parseFloat(c, 1);
             if (seconds < 0.0f) throwCommandError(c, "the time must be >= 0");
             v.cancelAfterS_ = seconds;
         }},
        {{"orbit", {"YAW PITCH"}, "turns the camera about its target (degrees; pitch raises the eye)"},
         [](Viewer& v, C c) { v.moveCamera(orbit(v.session_->viewCamera(), parseFloat(c, 1), parseFloat(c, 2))); }},
        {{"dolly", {"FACTOR"}, "moves towards the target by that factor of the distance"},
         [](Viewer& v, C c) {
             const float factor = parseFloat(c, 1);
             if (!(factor > 0.0f)) throwCommandError(c, "the factor must be > 0");
             v.moveCamera(dolly(v.session_->viewCamera(), factor, v.sceneRadius()));
         }},
        {{"set", {"TECHNIQUE.PARAM=VALUE"}, "as `penumbra render --set`: every light using the technique"},
         [](Viewer& v, C c) {
             const config::ParamOverride o = config::parseParamOverride(c.words[1]);
             const auto& lights = v.session_->config().lights;
             bool used = false;
             for (size_t i = 0; i < lights.size(); ++i) {
                 if (lights[i].shadow.technique != o.technique) continue;
                 v.session_->setParam(i, o.param, o.value, fmt::format("{}: set {}.{}", c.where, o.technique, o.param));
                 used = true;
             }
             if (!used) throwCommandError(c, fmt::format("no light uses the technique \"{}\"", core::shortText(o.technique)));
         }},
        {{"param", {"LIGHT NAME VALUE"}, "one light's parameter (LIGHT: name or index; VALUE: JSON, or else a string)"},
         [](Viewer& v, C c) {
             const size_t light = v.lightIndex(c.words[1], c);
             nlohmann::json value = nlohmann::json::parse(c.words[3], nullptr, false);
             if (value.is_discarded()) value = c.words[3];
             v.session_->setParam(light, c.words[2], value, fmt::format("{}: param {}", c.where, c.words[2]));
         }},
        {{"technique", {"LIGHT NAME"}, "switches a light's technique (`none` for unshadowed)"},
         [](Viewer& v, C c) { v.session_->setTechnique(v.lightIndex(c.words[1], c), c.words[2]); }},
        {{"culling", {"MODE"}, "none, frustum, light-occlusion, receiver-mask"},
         [](Viewer& v, C c) {
             v.session_->config().culling = config::parseCullingMode(c.words[1]);
             v.session_->changed(Change::Renderer);
         }},
        {{"light", {"LIGHT position|direction|target X Y Z", "LIGHT intensity V"}, "moves or dims a light"},
         [](Viewer& v, C c) {
             config::LightConfig& l = v.session_->config().lights.at(v.lightIndex(c.words[1], c));
             const std::string& field = parseChoice(c, 2, {"position", "direction", "target", "intensity"});
             if (field == "intensity") {
                 if (c.words.size() != 4) throwCommandError(c, "expected one value: `light LIGHT intensity V`");
                 const float intensity = parseFloat(c, 3);
                 if (intensity < 0.0f) throwCommandError(c, "the intensity must be >= 0");
                 l.light.intensity = intensity;
             } else if (c.words.size() != 6) {
                 throwCommandError(c, fmt::format("expected three values: `light LIGHT {} X Y Z`", field));
             } else if (const glm::vec3 p = parseVec3(c, 3); field == "position") {
                 l.light.position = p;
                 if (l.target && glm::length(*l.target - p) > 0.0f) l.light.direction = glm::normalize(*l.target - p);
             } else {
                 const glm::vec3 axis = field == "target" ? p - l.light.position : p;
                 if (!(glm::length(axis) > 0.0f)) throwCommandError(c, fmt::format("the {} gives no direction", field));
                 l.light.direction = glm::normalize(axis);
                 l.target = field == "target" ? std::optional<glm::vec3>(p) : std::nullopt;
             }
             v.session_->changed(Change::View);
         }},
        {{"show", {"IMAGE [linear|log|false-color]", "color"},
          "shows a graph image (fitted, zoom and pan reset, its default mapping and automatic range unless one is named), "
          "or the colour again"},
         [](Viewer& v, C c) {
             // The image's own default mapping (afterRender: false colour for a
             // classification, else linear; automatic range), unless the command names one.
             v.session_->showImage(c.words[1] == "color" ? std::string() : c.words[1]);
             v.resetDebugView();
             if (c.words.size() == 3) v.mapping_ = metrics::parseDebugMapping(c.words[2]);
             v.debugMappingChosen_ = c.words.size() == 3;
         }},
        {{"frames", {"N"}, "runs N frames of the loop before the next command"},
         [](Viewer& v, C c) { v.framesToRun_ = parseInt(c, 1, 1, 100000); }},
        {{"continuous", {"on|off"}, "renders every frame, or only after a change"},
         [](Viewer& v, C c) { v.continuous_ = parseOnOff(c); }},
        {{"vsync", {"on|off"}, "presents at the display's rate, or as fast as frames come"},
         [](Viewer& v, C c) { v.presenter_->setVsync(parseOnOff(c)); }},
        {{"ui", {"on|off"}, "shows or hides the panels (F1)"}, [](Viewer& v, C c) { v.showUi_ = parseOnOff(c); }},
        {{"panel", {"NAME open|closed"},
          "opens or closes a panel (file, scene, camera, render, lights, animation, compare, \"debug images\", timings)"},
         [](Viewer& v, C c) {
             static const std::set<std::string> names{"file",      "scene",   "camera",       "render", "lights",
                                                      "animation", "compare", "debug images", "timings"};
             const std::string name = panelKey(c.words[1]);
             if (!names.contains(name)) {
                 throwCommandError(c, fmt::format("\"{}\": expected one of file, scene, camera, render, lights, animation, "
                                                  "compare, \"debug images\" or timings",
                                                  core::shortText(c.words[1])));
             }
             v.panelOpen_[name] = parseChoice(c, 2, {"open", "closed"}) == "open";
         }},
        {{"panel-layer", {"on|off"}, "the panels' layer (on by default); off draws the panels every frame"},
         [](Viewer& v, C c) { v.presenter_->setPanelLayer(parseOnOff(c)); }},
        {{"screenshot", {"FILE.png"},
          "the view's image at its own size (the frame, B, the difference or the debug image mapped); a `.jpg` or `.jpeg` "
          "name writes JPEG, another name is an error"},
         [](Viewer& v, C c) { v.writeScreenshot(c.words[1], false); }},
        {{"screenshot-window", {"FILE.png"}, "the whole window, panels included (`.jpg`: JPEG, as `screenshot`)"},
         [](Viewer& v, C c) { v.writeScreenshot(c.words[1], true); }},
        {{"save", {"FILE.json"}, "the config as shown (`config::saveConfig`)"},
         [](Viewer& v, C c) {
             v.session_->renderIfChanged(false);
             v.session_->save(c.words[1]);
         }},
        {{"save-visibility", {"FILE.exr"},
          "every light's V as 32-bit floats, as `penumbra render --visibility-exr` writes them (one channel `<light name>.V` "
          "per light, and `Y`: the first light's; the README's \"Reading the visibility EXR\")"},
         [](Viewer& v, C c) {
             v.drawWithVisibility();
             frame::FrameRenderer& r = v.session_->renderer();
             std::vector<std::vector<float>> visibility;
             for (size_t l = 0; l < r.lightCount(); ++l) visibility.push_back(r.readVisibility(l));
             app::writeVisibilityExr(c.words[1], r.width(), r.height(), v.session_->config().lights, visibility);
             spdlog::info("wrote {} (V of {} light(s))", c.words[1], visibility.size());
         }},
        {{"widgets", {}, "prints the technique parameter widgets the panels drew (`widget LIGHT TECHNIQUE PARAM TYPE`)"},
         [](Viewer& v, C) {
             for (const std::string& w : v.drawnParamWidgets_) fmt::print("widget {}\n", w);
             std::fflush(stdout);
         }},
        {{"timings", {},
          "logs the rolling medians of every pass, the frame, the viewer's own cost, the shown frame's wall clock and the "
          "panels' cost (means, how many of the last frames built them, share of the frame), and for each light whether "
          "the last frame wrote its visibility image or shading evaluated it (only while nothing reads the images)"},
         [](Viewer& v, C) { v.printTimings(); }},
        {{"compare", {"TECHNIQUE|off"}, "B draws every light with TECHNIQUE (`reference`: 16 rays a pixel), or stops"},
         [](Viewer& v, C c) {
             if (c.words[1] == "off") {
                 v.comparison_.stop();
             } else {
                 v.startComparison(c.words[1]);
             }
         }},
        {{"compare-set", {"TECHNIQUE.PARAM=VALUE"}, "a parameter of B's technique, on every light B draws with it"},
         [](Viewer& v, C c) { v.comparison_.setParam(config::parseParamOverride(c.words[1]), c.where, v.session_->plugins()); }},
        {{"compare-view", {"a|b|split|difference"}, "what the view shows while B is of this view"},
         [](Viewer& v, C c) {
             v.comparison_.setView(*parseCompareView(parseChoice(c, 1, {"a", "b", "split", "difference"})));
         }},
        {{"wait-compare", {}, "frames go on until B is drawn for the current view (at most 600 s; B's failure ends the script)"},
         [](Viewer& v, C c) {
             if (!v.comparison_.on()) throwCommandError(c, "no comparison (compare TECHNIQUE first)");
             v.waitCompare_ = true;
             v.waitCompareDeadline_ = std::chrono::steady_clock::now() + std::chrono::seconds(600);
         }},
        {{"errors", {},
          "prints per light `error LIGHT pixels N rmse .. mae .. max .. above_0.05 .. umbra .. penumbra .. lit .. ssim ..`: "
          "A's error against B, as the Compare panel shows it"},
         [](Viewer& v, C c) {
             if (!v.comparison_.current()) throwCommandError(c, "B is not drawn for this view (wait-compare first)");
             const auto& lights = v.session_->shownConfig().lights;
             const auto& errors = v.comparison_.errors();
             for (size_t l = 0; l < errors.size() && l < lights.size(); ++l) {
                 const metrics::VisibilityComparison& e = errors[l];
                 fmt::print("error {} pixels {} rmse {:.6g} mae {:.6g} max {:.6g} above_0.05 {:.6g} umbra {:.6g} penumbra {:.6g} "
                            "lit {:.6g} ssim {:.6g}\n",
                            lights[l].name, e.all.pixels, e.all.rmse, e.all.mae, e.all.maxAbsError, e.all.percentAbove(0),
                            e.region(metrics::Region::Umbra).rmse, e.region(metrics::Region::Penumbra).rmse,
                            e.region(metrics::Region::Lit).rmse, e.ssim);
             }
             std::fflush(stdout);
         }},
        {{"record", {"start|stop"}, "records the camera path (a key per frame it moved) as tracks"},
         [](Viewer& v, C c) {
             if (parseChoice(c, 1, {"start", "stop"}) == "start") {
                 v.startRecording();
             } else {
                 if (!v.recording_) throwCommandError(c, "not recording");
                 v.stopRecording();
             }
         }},
        {{"time", {"SECONDS"}, "poses the animation at a time"},
         [](Viewer& v, C c) {
             const float t = parseFloat(c, 1);
             if (t < 0.0f || t > v.session_->duration()) {
                 throwCommandError(c, fmt::format("{} is outside the animation's [0, {}] s", t, v.session_->duration()));
             }
             v.session_->setTime(t);
         }},
        {{"play", {"on|off"}, "plays the animation (at wall-clock speed, looping), or stops it"},
         [](Viewer& v, C c) { v.playing_ = parseOnOff(c); }},
        {{"expect-error", {"TEXT"}, "fails unless the viewer shows an error containing TEXT"},
         [](Viewer& v, C c) {
             v.session_->renderIfChanged(false);
             const std::string& shown = v.session_->lastError();
             if (shown.find(c.words[1]) == std::string::npos) {
                 throwCommandError(c, fmt::format("expected an error with \"{}\", the viewer shows {}", core::shortText(c.words[1]),
                                                  shown.empty() ? "none" : "\"" + shown + "\""));
             }
         }},
        {{"expect-no-error", {}, "fails if the viewer shows an error"},
         [](Viewer& v, C c) {
             v.session_->renderIfChanged(false);
             if (!v.session_->lastError().empty()) throwCommandError(c, "the viewer shows an error: " + v.session_->lastError());
         }},
        // For tests that edit files while the viewer runs (hot reload polls the disk).
        {{"wait-for", {"FILE"}, "frames go on until FILE exists (at most 120 s)"},
         [](Viewer& v, C c) {
             v.waitUntil(c, [file = c.words[1]] {
                 std::error_code ec;
                 return fs::exists(file, ec);
             });
         }},
        {{"wait-error", {"TEXT"}, "frames go on until the viewer shows an error containing TEXT (at most 120 s)"},
         [](Viewer& v, C c) {
             v.waitUntil(c, [&v, text = c.words[1]] { return v.session_->lastError().find(text) != std::string::npos; });
         }},
        {{"wait-no-error", {}, "frames go on until the viewer shows no error (at most 120 s)"},
         [](Viewer& v, C c) { v.waitUntil(c, [&v] { return v.session_->lastError().empty(); }); }},
        {{"quit", {}, "closes the window; the exit code is 0, or 3 when the validation layer (`--validation`) reported anything"},
         [](Viewer& v, C) { v.quit_ = true; }},
    };
    return table;
}

} // namespace penumbra::viewer
