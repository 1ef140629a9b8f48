// The viewer's panels (Dear ImGui). A technique's parameters are drawn from the plugin's
// reflection (plugin::ParamSpec: type, range, unit, doc, choices) with no code for any one
// plugin: a new plugin appears with its widgets. Widgets clamp to the spec's range, so an
// invalid value cannot be entered; the session checks every value again (Session::setParam).
#include "Viewer.h"

#include "penumbra/core/Error.h"
#include "penumbra/plugin/Params.h"

#include <fmt/format.h>
#include <imgui.h>
#include <imgui_stdlib.h>

#include <algorithm>
#include <chrono>
#include <cfloat>
#include <cmath>
#include <functional>

namespace fs = std::filesystem;

namespace penumbra::viewer {
namespace {

void tooltip(const std::string& text)
{
    if (!text.empty() && ImGui::IsItemHovered()) ImGui::SetTooltip("%s", text.c_str());
}

std::string specTooltip(const plugin::ParamSpec& spec)
{
    std::string text = spec.doc;
    if (spec.type == plugin::ParamType::Int || spec.type == plugin::ParamType::Float) {
        text += fmt::format("\nrange [{}, {}]{}{}", spec.minValue, spec.maxValue, *spec.unit ? " " : "", spec.unit);
    }
    if (spec.type == plugin::ParamType::Enum) {
        text += fmt::format("\ndefault: {}", spec.choices[size_t(spec.defaultValue)]);
    } else if (spec.type == plugin::ParamType::Bool) {
        text += fmt::format("\ndefault: {}", spec.defaultValue != 0.0 ? "true" : "false");
    } else {
        text += fmt::format("\ndefault: {}", spec.defaultValue);
    }
    return text;
}

// A drag speed for world lengths: a small fraction of the scene.
float lengthSpeed(float radius) { return std::max(radius * 0.002f, 1e-6f); }

// How far a frame of a stack (A or B) has come: a pass that reports (the reference's
// tracing) gives its fraction of rows done; with none, the bar runs.
void frameProgressBar(const char* stack, uint32_t passes, double fraction, double seconds, float width)
{
    const ImVec2 size(width, 0.0f);
    if (passes > 0) {
        const std::string pass = passes > 1 ? fmt::format(" pass {},", passes) : std::string();
        ImGui::ProgressBar(float(fraction), size, fmt::format("{}: tracing{} {:.0f} %, {:.1f} s", stack, pass, 100.0 * fraction, seconds).c_str());
    } else {
        ImGui::ProgressBar(float(std::fmod(seconds, 2.0) / 2.0), size, fmt::format("{}: drawing, {:.1f} s", stack, seconds).c_str());
    }
}

bool dragVec3(const char* label, glm::vec3& v, float speed)
{
    return ImGui::DragFloat3(label, &v.x, speed, 0.0f, 0.0f, "%.4g");
}

} // namespace

std::string Viewer::panelKey(std::string name)
{
    std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    return name;
}

bool Viewer::panelHeader(const char* name, bool openAtFirst)
{
    // A script's `panel NAME open|closed`, applied once.
    if (const auto it = panelOpen_.find(panelKey(name)); it != panelOpen_.end()) {
        ImGui::SetNextItemOpen(it->second, ImGuiCond_Always);
        panelOpen_.erase(it);
    }
    return ImGui::CollapsingHeader(name, openAtFirst ? ImGuiTreeNodeFlags_DefaultOpen : ImGuiTreeNodeFlags_None);
}

void Viewer::drawPanels()
{
    drawnParamWidgets_.clear();
    const ImGuiIO& io = ImGui::GetIO();
    ImGui::SetNextWindowPos(ImVec2(0, 0));
    ImGui::SetNextWindowSize(ImVec2(panelWidth_ * uiScale_, io.DisplaySize.y));
    // No border: it would reach a pixel into the view, and the panels are drawn into a
    // layer of their own only while nothing of them does (Presenter::present).
    ImGui::PushStyleVar(ImGuiStyleVar_WindowBorderSize, 0.0f);
    ImGui::Begin("Penumbra", nullptr,
                 ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse |
                     ImGuiWindowFlags_NoBringToFrontOnFocus);
    ImGui::PopStyleVar();
    // Room for the labels on the right: the longest reflected name (20 characters) whole.
    ImGui::PushItemWidth(-ImGui::GetFontSize() * 13.0f);
    if (!message_.empty()) {
        const bool error = !session_->lastError().empty() && message_ == session_->lastError();
        ImGui::PushStyleColor(ImGuiCol_Text, error ? ImVec4(1.0f, 0.45f, 0.4f, 1.0f) : ImVec4(0.6f, 0.9f, 0.6f, 1.0f));
        ImGui::TextWrapped("%s", message_.c_str());
        ImGui::PopStyleColor();
        if (ImGui::SmallButton("dismiss")) {
            message_.clear();
            session_->clearError();
        }
        ImGui::Separator();
    }
    drawFilePanel();
    drawScenePanel();
    drawCameraPanel();
    drawRenderPanel();
    drawLightsPanel();
    drawAnimationPanel();
    drawComparePanel();
    drawDebugImagePanel();
    drawTimingsPanel();
    ImGui::PopItemWidth();
    ImGui::End();
    drawPixelInspector();
    if (comparison_.shows(CompareView::Difference)) drawDifferenceColourBar();
    // Split view: where A ends and B begins, and which is which.
    if (comparison_.shows(CompareView::Split) && viewRect_.extent.width > 0) {
        const float s = io.DisplayFramebufferScale.x > 0.0f ? 1.0f / io.DisplayFramebufferScale.x : 1.0f;
        const float x = (float(viewRect_.offset.x) + comparison_.splitAt() * float(viewRect_.extent.width)) * s;
        const float y0 = float(viewRect_.offset.y) * s, y1 = float(viewRect_.offset.y + int32_t(viewRect_.extent.height)) * s;
        ImDrawList* draw = ImGui::GetForegroundDrawList();
        draw->AddLine(ImVec2(x, y0), ImVec2(x, y1), IM_COL32(255, 255, 255, 200), 2.0f * uiScale_);
        const float pad = 6.0f * uiScale_;
        draw->AddText(ImVec2(x - pad - ImGui::CalcTextSize("A").x, y0 + pad), IM_COL32(255, 255, 255, 230), "A");
        draw->AddText(ImVec2(x + pad, y0 + pad), IM_COL32(255, 255, 255, 230), "B");
    }
}

void Viewer::drawFilePanel()
{
    if (!panelHeader("File", true)) return;
    ImGui::InputText("##open", &openPath_);
    ImGui::SameLine();
    if (ImGui::Button("Open")) {
        try {
            session_->open(openPath_);
            homeCamera_ = session_->config().camera;
            history_ = {};
            message_ = fmt::format("opened {}", openPath_);
        } catch (const std::exception& e) {
            message_ = e.what();
        }
    }
    tooltip("a scene config (.json) or a glTF file (.gltf, .glb)");
    ImGui::InputText("##save", &savePath_);
    ImGui::SameLine();
    if (ImGui::Button("Save")) {
        try {
            session_->save(savePath_);
            message_ = fmt::format("saved {}", savePath_);
        } catch (const std::exception& e) {
            message_ = e.what();
        }
    }
    tooltip("writes the config as shown: `penumbra render` of it draws this frame");
    if (ImGui::Button("Screenshot view")) {
        try {
            const std::string file = fs::path(savePath_).replace_extension(".png").string();
            writeScreenshot(file, false);
        } catch (const std::exception& e) {
            message_ = e.what();
        }
    }
    tooltip("the frame (or the debug image shown) at its own size, as PNG beside the config");
}

void Viewer::drawScenePanel()
{
    if (!panelHeader("Scene", false)) return;
    const scene::Scene& scene = session_->scene();
    const config::SceneSource& source = session_->config().scene;
    ImGui::Text("%s", source.describe().c_str());
    ImGui::Text("%zu instances, %zu meshes, %llu triangles", scene.instances.size(), scene.meshes.size(),
                static_cast<unsigned long long>(scene.triangleCount()));
    const scene::Aabb b = scene.bounds();
    ImGui::Text("bounds (%.4g, %.4g, %.4g)", b.min.x, b.min.y, b.min.z);
    ImGui::Text("    to (%.4g, %.4g, %.4g)", b.max.x, b.max.y, b.max.z);
    ImGui::Text("radius %.4g", b.radius());
}

void Viewer::drawCameraPanel()
{
    if (!panelHeader("Camera", true)) return;
    int mode = int(cameraMode_);
    ImGui::RadioButton("orbit", &mode, int(CameraMode::Orbit));
    ImGui::SameLine();
    ImGui::RadioButton("fly", &mode, int(CameraMode::Fly));
    ImGui::SameLine();
    ImGui::RadioButton("first person", &mode, int(CameraMode::FirstPerson));
    cameraMode_ = CameraMode(mode);
    tooltip(cameraMode_ == CameraMode::Orbit
                ? "left drag: orbit; middle or shift+left drag: pan; wheel: closer / farther; R: back to the file's camera"
                : "left or right drag: look; W/S/A/D: forward, back, left, right; Q/E: down, up; wheel: speed");
    if (hasCameraTrack(session_->config().animation)) {
        int follow = session_->followsCameraTrack() ? int(CameraFollow::Track) : int(CameraFollow::Free);
        bool picked = ImGui::RadioButton("follow track", &follow, int(CameraFollow::Track));
        ImGui::SameLine();
        picked |= ImGui::RadioButton("free camera", &follow, int(CameraFollow::Free));
        if (picked) session_->setCameraFollow(CameraFollow(follow));
        tooltip("the config's camera tracks (/camera/...) move the camera while it follows them; orbiting, flying or "
                "an edit below frees it from the pose drawn (the tracks stay in the config: Save writes them)");
    }
    // The pose drawn last (a followed track's included): an edit starts from what is seen.
    scene::Camera camera = session_->drawnCamera();
    panelCamera_ = camera;
    const float speed = lengthSpeed(sceneRadius());
    bool edited = dragVec3("position", camera.position, speed);
    edited |= dragVec3("target", camera.target, speed);
    edited |= ImGui::DragFloat("fov y (deg)", &camera.fovYDeg, 0.1f, 1.0f, 179.0f, "%.2f", ImGuiSliderFlags_AlwaysClamp);
    edited |= ImGui::DragFloat("near", &camera.nearWorld, speed * 0.01f, std::max(sceneRadius() * 1e-7f, 1e-30f),
                               sceneRadius() * 10.0f, "%.4g", ImGuiSliderFlags_AlwaysClamp | ImGuiSliderFlags_Logarithmic);
    if (cameraMode_ != CameraMode::Orbit) {
        ImGui::SliderFloat("speed (log2)", &flySpeedExponent_, -10.0f, 10.0f, "%.2f");
        tooltip(fmt::format("{:.4g} world units per second (a tenth of the scene's radius times 2^speed)",
                            flySpeed(sceneRadius(), flySpeedExponent_)));
    }
    // A target on the eye, or an up along the view, has no view: not taken.
    const glm::vec3 view = camera.target - camera.position;
    if (edited && glm::length(view) > 0.0f &&
        glm::length(glm::cross(glm::normalize(view), glm::normalize(camera.up))) > 1e-4f) {
        moveCamera(camera);
    }
    if (ImGui::Button("Back to the file's camera")) moveCamera(homeCamera_);
}

void Viewer::drawRenderPanel()
{
    if (!panelHeader("Render", false)) return;
    config::RenderConfig& c = session_->config();
    static const char* modes[] = {"none", "frustum", "light-occlusion", "receiver-mask"};
    int culling = int(c.culling);
    if (ImGui::Combo("culling", &culling, modes, 4)) {
        c.culling = config::CullingMode(culling);
        if (c.culling != config::CullingMode::ReceiverMask && c.culling != config::CullingMode::LightOcclusion) {
            c.shadowFocus = false;  // focusing needs what the camera sees (config's rule)
        }
        session_->changed(Change::Renderer);
    }
    tooltip("which shadow casters the light passes draw (docs/culling.md); every mode gives the same image");
    const bool canFocus = c.culling == config::CullingMode::ReceiverMask || c.culling == config::CullingMode::LightOcclusion;
    ImGui::BeginDisabled(!canFocus);
    if (ImGui::Checkbox("shadow focus", &c.shadowFocus)) session_->changed(Change::Renderer);
    ImGui::EndDisabled();
    tooltip("fit directional and spot maps to what the camera sees (needs receiver-mask or light-occlusion)");
    bool fixed = fixedSize_.has_value();
    if (ImGui::Checkbox("fixed size", &fixed)) {
        fixedSize_ = fixed ? std::optional(std::make_pair(c.width, c.height)) : std::nullopt;
    }
    tooltip("off: the frame is the view's size; on: this size, scaled into the view");
    if (fixedSize_) {
        int size[2] = {int(fixedSize_->first), int(fixedSize_->second)};
        if (ImGui::InputInt2("size", size, ImGuiInputTextFlags_EnterReturnsTrue)) {
            fixedSize_ = std::make_pair(uint32_t(std::clamp(size[0], 1, 16384)), uint32_t(std::clamp(size[1], 1, 16384)));
        }
    } else {
        ImGui::Text("%u x %u", c.width, c.height);
    }
    ImGui::Checkbox("render every frame", &continuous_);
    tooltip("off: a frame is rendered only when something changed; on: always (for timings)");
    bool vsync = presenter_->vsync();
    if (ImGui::Checkbox("vsync", &vsync)) presenter_->setVsync(vsync);
}

void Viewer::drawLightsPanel()
{
    if (!panelHeader("Lights", true)) return;
    config::RenderConfig& c = session_->config();
    const float speed = lengthSpeed(sceneRadius());
    std::optional<size_t> remove;
    for (size_t i = 0; i < c.lights.size(); ++i) {
        config::LightConfig& lc = c.lights[i];
        scene::Light& l = lc.light;
        ImGui::PushID(int(i));
        const std::string label = fmt::format("{} ({}, {})###light", lc.name, scene::lightTypeName(l.type), lc.shadow.technique);
        if (ImGui::TreeNodeEx(label.c_str(), i == 0 ? ImGuiTreeNodeFlags_DefaultOpen : 0)) {
            Change change = Change::None;
            int type = int(l.type);
            static const char* types[] = {"directional", "spot", "point", "rect", "disk"};
            if (ImGui::Combo("type", &type, types, 5)) {
                l.type = scene::LightType(type);
                if (l.type == scene::LightType::Directional) lc.target.reset();
                change = Change::Renderer;
            }
            if (l.type != scene::LightType::Directional && dragVec3("position", l.position, speed)) {
                if (lc.target && glm::length(*lc.target - l.position) > 0.0f) l.direction = glm::normalize(*lc.target - l.position);
                change = std::max(change, Change::View);
            }
            if (l.type != scene::LightType::Point) {
                glm::vec3 d = l.direction;
                if (ImGui::DragFloat3("direction", &d.x, 0.005f, -1.0f, 1.0f, "%.3f") && glm::length(d) > 1e-6f) {
                    l.direction = glm::normalize(d);
                    lc.target.reset();  // aimed by hand now
                    change = std::max(change, Change::View);
                }
                tooltip(l.type == scene::LightType::Directional ? "the way the light travels" : "the axis it shines along");
            }
            if (ImGui::DragFloat("intensity", &l.intensity, std::max(l.intensity * 0.01f, 1e-3f), 0.0f, 1e12f, "%.4g",
                                 ImGuiSliderFlags_AlwaysClamp)) {
                change = std::max(change, Change::View);
            }
            tooltip(l.type == scene::LightType::Directional ? "irradiance on a surface facing it (W/m2)"
                                                            : "radiant intensity along the axis (W/sr)");
            if (ImGui::ColorEdit3("colour", &l.color.x, ImGuiColorEditFlags_Float)) change = std::max(change, Change::View);
            switch (l.type) {
            case scene::LightType::Directional:
                if (ImGui::DragFloat("angular diameter", &l.angularDiameterDeg, 0.01f, 0.0f, 90.0f, "%.3f deg",
                                     ImGuiSliderFlags_AlwaysClamp))
                    change = Change::Renderer;
                break;
            case scene::LightType::Spot:
                if (ImGui::DragFloat("outer cone", &l.outerConeDeg, 0.1f, 0.01f, 89.0f, "%.2f deg", ImGuiSliderFlags_AlwaysClamp)) {
                    l.innerConeDeg = std::min(l.innerConeDeg, l.outerConeDeg);
                    change = Change::Renderer;
                }
                if (ImGui::DragFloat("inner cone", &l.innerConeDeg, 0.1f, 0.0f, l.outerConeDeg, "%.2f deg", ImGuiSliderFlags_AlwaysClamp))
                    change = Change::Renderer;
                break;
            case scene::LightType::Point:
                if (ImGui::DragFloat("radius", &l.radiusWorld, speed, 0.0f, 1e9f, "%.4g", ImGuiSliderFlags_AlwaysClamp))
                    change = Change::Renderer;
                break;
            case scene::LightType::Rect:
                if (ImGui::DragFloat2("size", &l.sizeWorld.x, speed, 0.0f, 1e9f, "%.4g", ImGuiSliderFlags_AlwaysClamp))
                    change = Change::Renderer;
                break;
            case scene::LightType::Disk:
                if (ImGui::DragFloat("radius", &l.radiusWorld, speed, 0.0f, 1e9f, "%.4g", ImGuiSliderFlags_AlwaysClamp))
                    change = Change::Renderer;
                break;
            }
            session_->changed(change);
            drawTechniquePanel(i);
            ImGui::BeginDisabled(c.lights.size() <= 1);
            if (ImGui::SmallButton("remove light")) remove = i;
            ImGui::EndDisabled();
            ImGui::TreePop();
        }
        ImGui::PopID();
    }
    if (remove) {
        try {
            session_->removeLight(*remove);
        } catch (const std::exception& e) {
            message_ = e.what();
        }
    }
    ImGui::BeginDisabled(c.lights.size() >= config::kMaxLights);
    if (ImGui::Button("Add a spot light")) {
        const scene::Aabb b = session_->scene().bounds();
        config::LightConfig lc;
        lc.light.type = scene::LightType::Spot;
        lc.light.position = b.center() + glm::vec3(0.3f, 1.5f, 0.2f) * sceneRadius();
        lc.light.direction = glm::normalize(b.center() - lc.light.position);
        lc.light.outerConeDeg = 40.0f;
        lc.light.innerConeDeg = 32.0f;
        // As bright at the scene as the default 300 W/sr light is at 10 units.
        const float distance = glm::length(b.center() - lc.light.position);
        lc.light.intensity = 3.0f * distance * distance;
        try {
            session_->addLight(lc);
        } catch (const std::exception& e) {
            message_ = e.what();
        }
    }
    ImGui::EndDisabled();
}

void Viewer::drawTechniquePanel(size_t light)
{
    config::ShadowSettings& shadow = session_->config().lights[light].shadow;
    if (ImGui::BeginCombo("technique", shadow.technique.c_str())) {
        for (const std::string& name : session_->techniqueNames()) {
            if (ImGui::Selectable(name.c_str(), name == shadow.technique)) {
                try {
                    session_->setTechnique(light, name);
                } catch (const std::exception& e) {
                    message_ = e.what();
                }
            }
        }
        ImGui::EndCombo();
    }
    const std::optional<plugin::ParamValues> values = session_->params(light);
    if (!values) return;
    const std::string& lightName = session_->config().lights[light].name;
    const std::string where = fmt::format("viewer: {}.", lightName);
    drawParamWidgets(fmt::format("{}/{}", light, shadow.technique), lightName, *values,
                     [&](const plugin::ParamSpec& spec, const nlohmann::json& value) {
                         try {
                             session_->setParam(light, spec.name, value, where + spec.name);
                         } catch (const std::exception& e) {
                             message_ = e.what();
                         }
                     });
}

// One widget per reflected parameter (see the file comment); `apply` takes a new value.
void Viewer::drawParamWidgets(const std::string& key, const std::string& lightName, const plugin::ParamValues& values,
                              const std::function<void(const plugin::ParamSpec&, const nlohmann::json&)>& apply)
{
    const std::string& technique = values.pluginName();
    for (const plugin::ParamSpec& spec : values.specs()) {
        // An odd-only kernel (ParamSpec::odd: its range's ends are odd) steps by 2.
        const bool odd = spec.odd;
        const int intLo = int(spec.minValue), intHi = int(spec.maxValue);
        drawnParamWidgets_.push_back(
            fmt::format("{} {} {} {}{}", lightName, technique, spec.name, plugin::paramTypeName(spec.type),
                        spec.type == plugin::ParamType::Int ? fmt::format(" {}..{} step {}", intLo, intHi, odd ? 2 : 1) : ""));
        // The unit goes with the value, not the label: the label column keeps room for the name.
        const std::string label = spec.name;
        std::string unit;  // " texels", as printf text
        for (const char* c = spec.unit; *c; ++c) unit += *c == '%' ? std::string("%%") : std::string(1, *c);
        if (!unit.empty()) unit = " " + unit;
        switch (spec.type) {
        case plugin::ParamType::Bool: {
            bool v = values.getBool(spec.name);
            if (ImGui::Checkbox(label.c_str(), &v)) apply(spec, v);
            break;
        }
        case plugin::ParamType::Int:
        case plugin::ParamType::Float: {
            // A whole new renderer per step of a drag would stall it: the value being
            // dragged is kept here and taken when the widget lets go.
            const std::string editKey = fmt::format("{}/{}", key, spec.name);
            const auto editing = editing_.find(editKey);
            const double lo = spec.minValue, hi = spec.maxValue;
            bool changed = false;
            double value = 0.0;
            if (odd) {
                // The slider moves over the odd values' index and shows the value.
                const int current = editing != editing_.end() ? int(editing->second) : values.getInt(spec.name);
                int k = std::clamp((current - intLo) / 2, 0, (intHi - intLo) / 2);
                changed = ImGui::SliderInt(label.c_str(), &k, 0, (intHi - intLo) / 2, fmt::format("{}{}", intLo + 2 * k, unit).c_str(),
                                           ImGuiSliderFlags_AlwaysClamp);
                value = intLo + 2 * std::clamp(k, 0, (intHi - intLo) / 2);
            } else if (spec.type == plugin::ParamType::Int) {
                int v = editing != editing_.end() ? int(editing->second) : values.getInt(spec.name);
                const std::string format = "%d" + unit;
                changed = hi - lo <= 64 ? ImGui::SliderInt(label.c_str(), &v, int(lo), int(hi), format.c_str(), ImGuiSliderFlags_AlwaysClamp)
                                        : ImGui::DragInt(label.c_str(), &v, float(std::max(1.0, (hi - lo) / 2000.0)), int(lo),
                                                         int(hi), format.c_str(), ImGuiSliderFlags_AlwaysClamp);
                value = std::clamp(double(v), lo, hi);
            } else {
                float v = editing != editing_.end() ? float(editing->second) : values.getFloat(spec.name);
                // Wide positive ranges (biases, radii) are dragged on a log scale.
                const bool logarithmic = lo > 0.0 && hi / lo > 1000.0;
                changed = ImGui::DragFloat(label.c_str(), &v, float(std::max((hi - lo) / 2000.0, 1e-6)), float(lo), float(hi),
                                           ("%.5g" + unit).c_str(),
                                           ImGuiSliderFlags_AlwaysClamp | (logarithmic ? ImGuiSliderFlags_Logarithmic : 0));
                value = std::clamp(double(v), lo, hi);
            }
            if (changed) editing_[editKey] = value;
            if (!ImGui::IsItemActive() && editing_.count(editKey)) {
                const double taken = editing_[editKey];
                editing_.erase(editKey);
                if (spec.type == plugin::ParamType::Int) {
                    apply(spec, int(taken));
                } else {
                    apply(spec, taken);
                }
            }
            break;
        }
        case plugin::ParamType::Enum: {
            const uint32_t current = values.getEnumIndex(spec.name);
            if (ImGui::BeginCombo(label.c_str(), spec.choices[current])) {
                for (uint32_t k = 0; k < spec.choiceCount; ++k) {
                    if (ImGui::Selectable(spec.choices[k], k == current)) apply(spec, spec.choices[k]);
                }
                ImGui::EndCombo();
            }
            break;
        }
        }
        tooltip(specTooltip(spec));
    }
}

void Viewer::drawAnimationPanel()
{
    if (!panelHeader("Animation", false)) return;
    const float end = session_->duration();
    ImGui::BeginDisabled(end <= 0.0f || recording_);
    if (ImGui::Button(playing_ ? "Pause" : "Play")) playing_ = !playing_;
    ImGui::SameLine();
    float t = session_->time();
    if (ImGui::SliderFloat("time (s)", &t, 0.0f, std::max(end, 1e-3f), "%.3f")) {
        playing_ = false;
        session_->setTime(t);
    }
    ImGui::EndDisabled();
    const config::Animation& a = session_->config().animation;
    for (const config::ScenePart& part : session_->config().scene.parts) {
        if (!part.animation.empty()) ImGui::Text("%s: glTF animation \"%s\"", part.name.c_str(), part.animation.c_str());
    }
    ImGui::Text("%zu track(s), %.3f s at %.4g fps; `penumbra render` draws %u frame(s)", a.tracks.size(), end, a.fps,
                session_->config().frames);
    if (!recording_) {
        if (ImGui::Button("Record the camera")) startRecording();
        tooltip("every frame the camera moves becomes a key of /camera/position and /camera/target (replacing the "
                "config's camera tracks); Save writes them with the config");
    } else {
        if (ImGui::Button("Stop recording")) stopRecording();
        ImGui::SameLine();
        ImGui::Text("%zu keys", recordedPosition_.keys.size());
    }
}

void Viewer::drawComparePanel()
{
    if (!panelHeader("Compare", false)) return;
    bool on = comparison_.on();
    if (ImGui::Checkbox("compare with a second stack (B)", &on)) {
        try {
            if (on) {
                startComparison("reference");
            } else {
                comparison_.stop();
            }
        } catch (const std::exception& e) {
            message_ = e.what();
        }
    }
    tooltip("B draws the same view with other techniques (the ray-traced reference by default) on a worker thread, "
            "once the view has rested; the table gives the shown stack's error against it");
    if (!comparison_.on()) return;
    const auto& lights = session_->config().lights;
    std::vector<config::ShadowSettings>& bShadows = comparison_.bShadows();
    for (size_t i = 0; i < bShadows.size() && i < lights.size(); ++i) {
        ImGui::PushID(int(1000 + i));
        config::ShadowSettings& b = bShadows[i];
        const std::string label = fmt::format("B for {}", lights[i].name);
        bool changed = false;
        if (ImGui::BeginCombo(label.c_str(), b.technique.c_str())) {
            for (const std::string& name : session_->techniqueNames()) {
                if (ImGui::Selectable(name.c_str(), name == b.technique) && name != b.technique) {
                    b.technique = name;
                    b.params.clear();
                    changed = true;
                }
            }
            ImGui::EndCombo();
        }
        if (!b.unshadowed() && ImGui::TreeNode("B's parameters")) {
            try {
                const plugin::ParamValues values = plugin::resolveParams(session_->plugins().load(b.technique), b);
                drawParamWidgets(fmt::format("B/{}/{}", i, b.technique), "B/" + lights[i].name, values,
                                 [&](const plugin::ParamSpec& spec, const nlohmann::json& value) {
                                     config::ShadowSettings trial = b;
                                     trial.setParam(spec.name, value, fmt::format("viewer: B {}.{}", lights[i].name, spec.name));
                                     try {
                                         plugin::resolveParams(session_->plugins().load(trial.technique), trial);
                                         b = std::move(trial);
                                         changed = true;
                                     } catch (const std::exception& e) {
                                         message_ = e.what();
                                     }
                                 });
            } catch (const std::exception& e) {
                message_ = e.what();
            }
            ImGui::TreePop();
        }
        if (changed) comparison_.settingsChanged();
        ImGui::PopID();
    }
    if (const DrawerProgress progress = comparison_.progress(); progress.busy) {
        frameProgressBar("B", progress.passes, progress.fraction, progress.seconds, -ImGui::GetFontSize() * 5.0f);
        ImGui::SameLine();
        if (ImGui::Button("Cancel")) comparison_.cancel();
    } else if (const ComparisonResult* b = comparison_.result()) {
        ImGui::Text("B: drawn in %.2f s for this view", b->seconds);
    } else if (!comparison_.bError().empty()) {
        ImGui::TextWrapped("B failed: %s", comparison_.bError().c_str());
    } else {
        ImGui::TextUnformatted("B: waiting for the view to rest");
    }
    int mode = int(comparison_.view());
    ImGui::RadioButton("A", &mode, int(CompareView::A));
    ImGui::SameLine();
    ImGui::RadioButton("B", &mode, int(CompareView::B));
    ImGui::SameLine();
    ImGui::RadioButton("split", &mode, int(CompareView::Split));
    ImGui::SameLine();
    ImGui::RadioButton("difference", &mode, int(CompareView::Difference));
    comparison_.setView(CompareView(mode));
    if (comparison_.view() == CompareView::Split) {
        float splitAt = comparison_.splitAt();
        if (ImGui::SliderFloat("split at", &splitAt, 0.05f, 0.95f, "%.2f")) comparison_.setSplitAt(splitAt);
    }
    if (comparison_.view() == CompareView::Difference) {
        int light = comparison_.differenceLight();
        float scale = comparison_.differenceScale();
        bool redraw = ImGui::SliderInt("light", &light, 0, std::max(int(lights.size()) - 1, 0));
        redraw |= ImGui::SliderFloat("saturates at |dV|", &scale, 0.01f, 1.0f, "%.2f", ImGuiSliderFlags_AlwaysClamp);
        if (redraw) {
            comparison_.setDifference(light, scale);
            uploadComparisonImages();
        }
    }
    const std::vector<metrics::VisibilityComparison>& errors = comparison_.errors();
    if (comparison_.current() && !errors.empty() &&
        ImGui::BeginTable("errors", 6, ImGuiTableFlags_RowBg | ImGuiTableFlags_SizingStretchProp)) {
        ImGui::TableSetupColumn("light");
        ImGui::TableSetupColumn("RMSE");
        ImGui::TableSetupColumn("max");
        ImGui::TableSetupColumn("umbra");
        ImGui::TableSetupColumn("penumbra");
        ImGui::TableSetupColumn("lit");
        ImGui::TableHeadersRow();
        for (size_t l = 0; l < errors.size() && l < lights.size(); ++l) {
            const metrics::VisibilityComparison& e = errors[l];
            ImGui::TableNextRow();
            ImGui::TableNextColumn();
            ImGui::TextUnformatted(lights[l].name.c_str());
            ImGui::TableNextColumn();
            ImGui::Text("%.4f", e.all.rmse);
            tooltip(fmt::format("RMSE of V over {} pixels with geometry; MAE {:.4f}; {:.2f} % wrong by more than 0.05; SSIM {:.4f}",
                                e.all.pixels, e.all.mae, e.all.percentAbove(0), e.ssim));
            ImGui::TableNextColumn();
            ImGui::Text("%.3f", e.all.maxAbsError);
            tooltip(fmt::format("at ({}, {}): A {:.4f}, B {:.4f}", e.all.maxX, e.all.maxY, e.all.testAtMax, e.all.referenceAtMax));
            for (const metrics::Region r : {metrics::Region::Umbra, metrics::Region::Penumbra, metrics::Region::Lit}) {
                ImGui::TableNextColumn();
                ImGui::Text("%.4f", e.region(r).rmse);
                tooltip(fmt::format("RMSE where B is {} ({} pixels)", metrics::regionName(r), e.region(r).pixels));
            }
        }
        ImGui::EndTable();
    }
}

void Viewer::drawDebugImagePanel()
{
    if (!panelHeader("Debug images", false)) return;
    const std::string shown = session_->shownImage().empty() ? "color" : session_->shownImage();
    if (ImGui::BeginCombo("image", shown.c_str())) {
        if (ImGui::Selectable("color", session_->shownImage().empty())) session_->showImage("");
        for (const std::string& name : session_->renderer().imageNames()) {
            if (name == "color") continue;
            if (ImGui::Selectable(name.c_str(), name == session_->shownImage())) {
                try {
                    session_->showImage(name);
                    resetDebugView();
                } catch (const std::exception& e) {
                    message_ = e.what();
                }
            }
        }
        ImGui::EndCombo();
    }
    tooltip("any image a pass of the frame writes; its passes run only while it is shown");
    static const char* mappings[] = {"linear", "log", "false-color"};
    int mapping = int(mapping_);
    bool remap = ImGui::Combo("mapping", &mapping, mappings, 3);
    mapping_ = metrics::DebugMapping(mapping);
    debugMappingChosen_ |= remap;
    remap |= ImGui::Checkbox("automatic range", &autoRange_);
    ImGui::BeginDisabled(autoRange_);
    remap |= ImGui::InputDouble("min", &range_.min, 0.0, 0.0, "%.6g");
    remap |= ImGui::InputDouble("max", &range_.max, 0.0, 0.0, "%.6g");
    ImGui::EndDisabled();
    if (!std::isfinite(range_.min) || !std::isfinite(range_.max) || range_.min > range_.max) range_ = {0.0, 1.0};
    if (remap && shownValues_) {
        if (autoRange_) range_ = metrics::finiteRange(*shownValues_, mapping_);
        debugUpload_->set(shownValues_->width, shownValues_->height, metrics::debugImageRgba(*shownValues_, mapping_, range_));
    }
    if (shownValues_) {
        ImGui::Text("%u x %u, %u channel(s), zoom %.3g", shownValues_->width, shownValues_->height, shownValues_->channels,
                    debugZoom_);
        tooltip("wheel over the image: zoom; drag: pan; showing an image again resets both");
        ImGui::SameLine();
        if (ImGui::SmallButton("fit")) resetDebugView();
        if (!debugClasses_.empty()) {
            // A classification's legend: each value in the colour the mapping gives it.
            metrics::DebugImageValues swatches{uint32_t(debugClasses_.size()), 1, 1, {}};
            for (const auto& [value, count] : debugClasses_) swatches.values.push_back(value);
            const std::vector<uint8_t> rgba = metrics::debugImageRgba(swatches, mapping_, range_);
            for (size_t i = 0; i < debugClasses_.size(); ++i) {
                const ImVec4 colour(rgba[4 * i] / 255.0f, rgba[4 * i + 1] / 255.0f, rgba[4 * i + 2] / 255.0f, 1.0f);
                ImGui::ColorButton(fmt::format("##class{}", i).c_str(), colour, ImGuiColorEditFlags_NoTooltip);
                ImGui::SameLine();
                ImGui::Text("%.6g: %.1f %% of the pixels", debugClasses_[i].first,
                            100.0 * double(debugClasses_[i].second) / double(std::max<size_t>(shownValues_->values.size(), 1)));
            }
        }
        if (range_.nonFinite) ImGui::Text("%llu non-finite values (magenta)", static_cast<unsigned long long>(range_.nonFinite));
    }
}

void Viewer::drawTimingsPanel()
{
    if (!panelHeader("Timings", true)) return;
    ImGui::Text("frame %.2f ms (sum of passes %.2f ms GPU)", TimingHistory::median(history_.frameMs),
                TimingHistory::median(history_.sumGpuMs));
    ImGui::Text("viewer: panels + present %.2f ms", TimingHistory::median(history_.viewerMs));
    tooltip("the viewer's own cost per shown frame, beside the frame's");
    ImGui::Text("panels: %.2f ms CPU + %.2f ms GPU (%.1f %% of the frame)", TimingHistory::mean(history_.panelsCpuMs),
                TimingHistory::mean(history_.panelsGpuMs), history_.panelsShare());
    tooltip("building the panels (only after input or a change, and 4 times a second) and drawing them (into a layer "
            "of their own, copied into the window between changes); means per shown frame");
    if (presenter_->lastTimes().valid) {
        ImGui::Text("view blits: %.2f ms GPU", presenter_->lastTimes().viewsMs);
        tooltip("the shown images (the frame, B, a debug image) copied or scaled into the window, last frame");
    }
    ImGui::Text("last edit to its image: %.1f ms", session_->lastRebuildMs());
    tooltip("a technique, parameter, culling or size change builds a new renderer (its shaders and pipelines) and draws "
            "its first frame");
    const frame::FrameRenderer& r = session_->renderer();
    ImGui::Text("transient memory %.1f MiB (%.1f MiB without aliasing)",
                double(r.executor().transientBytesAllocated()) / 1048576.0,
                double(r.executor().transientBytesWithoutAliasing()) / 1048576.0);
    // Per technique: the transient resources its passes use (named by its prefix, "light0.pcss.").
    if (ImGui::TreeNode("memory per technique")) {
        const std::vector<graph::TransientMemory> memory = r.executor().transientMemory();
        VkDeviceSize total = 0, techniques = 0;
        for (const graph::TransientMemory& m : memory) total += m.bytes;
        for (size_t l = 0; l < r.lightCount(); ++l) {
            const std::string prefix = r.shadowPassPrefix(l);
            VkDeviceSize bytes = 0;
            for (const graph::TransientMemory& m : memory) bytes += m.name.rfind(prefix, 0) == 0 ? m.bytes : 0;
            techniques += bytes;
            ImGui::BulletText("%s (%s): %.2f MiB", session_->shownConfig().lights[l].name.c_str(),
                              r.techniqueName(l).empty() ? "unshadowed" : r.techniqueName(l).c_str(), double(bytes) / 1048576.0);
        }
        ImGui::BulletText("engine (G-buffer, colour, visibility images): %.2f MiB", double(total - techniques) / 1048576.0);
        ImGui::TextDisabled("before aliasing; the total above is after");
        ImGui::TreePop();
    }
    const visibility::CullingStats& s = session_->lastTimings().culling;
    if (session_->config().culling != config::CullingMode::None) {
        ImGui::Text("casters drawn %llu (%llu triangles), receivers %llu", static_cast<unsigned long long>(s.castersDrawn),
                    static_cast<unsigned long long>(s.trianglesDrawn), static_cast<unsigned long long>(s.receivers));
        ImGui::Text("culling: camera %.2f, masks %.2f, casters %.2f ms; %llu queries", s.cameraMs, s.maskMs, s.casterCullMs,
                    static_cast<unsigned long long>(s.queriesIssued));
    }
    if (ImGui::BeginTable("passes", 3, ImGuiTableFlags_RowBg)) {
        // The plots get a width of their own: one that fills its column gets none.
        const float plotWidth = ImGui::GetFontSize() * 8.0f;
        ImGui::TableSetupColumn("pass", ImGuiTableColumnFlags_WidthStretch);
        ImGui::TableSetupColumn("GPU ms", ImGuiTableColumnFlags_WidthFixed);
        ImGui::TableSetupColumn("last frames", ImGuiTableColumnFlags_WidthFixed, plotWidth);
        ImGui::TableHeadersRow();
        for (const std::string& pass : history_.order) {
            const std::deque<float>& gpu = history_.gpuMs[pass];
            ImGui::TableNextRow();
            ImGui::TableNextColumn();
            ImGui::TextUnformatted(pass.c_str());
            ImGui::TableNextColumn();
            ImGui::Text("%.2f", TimingHistory::median(gpu));
            tooltip(fmt::format("median of the last {} frames; CPU {:.3f} ms", gpu.size(),
                                TimingHistory::median(history_.cpuMs[pass])));
            ImGui::TableNextColumn();
            std::vector<float> values(gpu.begin(), gpu.end());
            ImGui::PushID(pass.c_str());
            ImGui::PlotLines("##plot", values.data(), int(values.size()), 0, nullptr, 0.0f, FLT_MAX,
                             ImVec2(plotWidth, ImGui::GetTextLineHeight()));
            ImGui::PopID();
        }
        ImGui::EndTable();
    }
    if (ImGui::TreeNode("compiled graph")) {
        const graph::CompiledGraph& g = session_->renderer().compiledGraph();
        for (const auto& pass : g.passes) ImGui::BulletText("%s", pass.name.c_str());
        ImGui::TreePop();
    }
}

// The difference view's scale: the false-colour ramp from 0 to the saturating |dV|, in the
// view's lower right corner.
void Viewer::drawDifferenceColourBar()
{
    if (viewRect_.extent.width == 0) return;
    const ImGuiIO& io = ImGui::GetIO();
    const float s = io.DisplayFramebufferScale.x > 0.0f ? 1.0f / io.DisplayFramebufferScale.x : 1.0f;
    constexpr uint32_t kSteps = 64;
    metrics::DebugImageValues ramp;
    ramp.width = kSteps;
    ramp.height = 1;
    for (uint32_t i = 0; i < kSteps; ++i) ramp.values.push_back((float(i) + 0.5f) / float(kSteps));
    const std::vector<uint8_t> rgba = metrics::debugImageRgba(ramp, metrics::DebugMapping::FalseColor, {0.0, 1.0});
    const float pad = 10.0f * uiScale_, height = ImGui::GetTextLineHeight();
    const float width = std::min(ImGui::GetFontSize() * 16.0f, float(viewRect_.extent.width) * s - 2.0f * pad);
    const ImVec2 low(float(viewRect_.offset.x + int32_t(viewRect_.extent.width)) * s - pad - width,
                     float(viewRect_.offset.y + int32_t(viewRect_.extent.height)) * s - pad - 2.0f * height);
    ImDrawList* draw = ImGui::GetForegroundDrawList();
    draw->AddRectFilled(ImVec2(low.x - 4.0f, low.y - 4.0f), ImVec2(low.x + width + 4.0f, low.y + 2.0f * height + 4.0f),
                        IM_COL32(0, 0, 0, 170));
    for (uint32_t i = 0; i < kSteps; ++i) {
        const float x0 = low.x + width * float(i) / float(kSteps), x1 = low.x + width * float(i + 1) / float(kSteps);
        draw->AddRectFilled(ImVec2(x0, low.y), ImVec2(x1, low.y + height),
                            IM_COL32(rgba[4 * i], rgba[4 * i + 1], rgba[4 * i + 2], 255));
    }
    const ImU32 text = IM_COL32(255, 255, 255, 235);
    const auto& lights = session_->shownConfig().lights;
    const std::string high = fmt::format("{:.2f}", comparison_.differenceScale()),
                      mid = fmt::format("|dV| of {}", lights.at(size_t(std::clamp(comparison_.differenceLight(), 0, int(lights.size()) - 1))).name);
    draw->AddText(ImVec2(low.x, low.y + height), text, "0");
    draw->AddText(ImVec2(low.x + 0.5f * (width - ImGui::CalcTextSize(mid.c_str()).x), low.y + height), text, mid.c_str());
    draw->AddText(ImVec2(low.x + width - ImGui::CalcTextSize(high.c_str()).x, low.y + height), text, high.c_str());
}

// Over the view while A draws a long frame (onFrameProgress): what is drawing, how far, Cancel.
void Viewer::drawBusyOverlay(const Session::FrameProgress& progress)
{
    const ImGuiIO& io = ImGui::GetIO();
    const float s = io.DisplayFramebufferScale.x > 0.0f ? 1.0f / io.DisplayFramebufferScale.x : 1.0f;
    const ImVec2 centre((float(viewRect_.offset.x) + 0.5f * float(viewRect_.extent.width)) * s,
                        (float(viewRect_.offset.y) + 0.5f * float(viewRect_.extent.height)) * s);
    const float width = std::min(ImGui::GetFontSize() * 26.0f, 0.9f * float(viewRect_.extent.width) * s);
    ImGui::SetNextWindowPos(centre, ImGuiCond_Always, ImVec2(0.5f, 0.5f));
    ImGui::SetNextWindowSize(ImVec2(width, 0.0f));
    ImGui::Begin("A is drawing", nullptr,
                 ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoSavedSettings);
    ImGui::TextWrapped("%s", progress.rebuild ? "A: drawing the edit (the last complete frame is shown)"
                                              : "A: drawing the new view");
    frameProgressBar("A", progress.passes, progress.fraction, progress.seconds, -1.0f);
    if (ImGui::Button("Cancel")) session_->cancelFrame();
    ImGui::SameLine();
    ImGui::TextDisabled("keeps the last complete image");
    ImGui::End();
}

// The value under the cursor: the colour and every light's V, or the debug image's values.
void Viewer::drawPixelInspector()
{
    inspecting_ = false;
    const ImGuiIO& io = ImGui::GetIO();
    if (io.WantCaptureMouse || viewRect_.extent.width == 0 || session_->framesRendered() == 0) return;
    const float fbScale = io.DisplayFramebufferScale.x > 0.0f ? io.DisplayFramebufferScale.x : 1.0f;
    const float fx = (io.MousePos.x * fbScale - float(viewRect_.offset.x)) / float(viewRect_.extent.width);
    const float fy = (io.MousePos.y * fbScale - float(viewRect_.offset.y)) / float(viewRect_.extent.height);
    if (!(fx >= 0.0f && fx < 1.0f && fy >= 0.0f && fy < 1.0f)) return;
    if (ImGui::IsMouseDown(ImGuiMouseButton_Left) || ImGui::IsMouseDown(ImGuiMouseButton_Right)) return;
    if (shownValues_ && !session_->shownImage().empty()) {
        // The texel under the cursor, where the image is placed (zoom and pan).
        VkRect2D target{}, source{};
        if (!debugImageBlit({shownValues_->width, shownValues_->height}, target, source)) return;
        const float tx = (io.MousePos.x * fbScale - float(target.offset.x)) / float(target.extent.width);
        const float ty = (io.MousePos.y * fbScale - float(target.offset.y)) / float(target.extent.height);
        if (!(tx >= 0.0f && tx < 1.0f && ty >= 0.0f && ty < 1.0f)) return;
        const uint32_t x = std::min(uint32_t(float(source.offset.x) + tx * float(source.extent.width)), shownValues_->width - 1);
        const uint32_t y = std::min(uint32_t(float(source.offset.y) + ty * float(source.extent.height)), shownValues_->height - 1);
        std::string values;
        for (uint32_t ch = 0; ch < shownValues_->channels; ++ch) {
            values += fmt::format("{}{:.6g}", ch ? ", " : "",
                                  shownValues_->values[(size_t(y) * shownValues_->width + x) * shownValues_->channels + ch]);
        }
        ImGui::SetTooltip("%s (%u, %u)\n%s", session_->shownImage().c_str(), x, y, values.c_str());
        return;
    }
    // The inspector reads V: the frame is drawn again with its images where it kept none.
    inspecting_ = true;
    const frame::FrameRenderer& r = session_->renderer();
    const uint32_t x = std::min(uint32_t(fx * float(r.width())), r.width() - 1);
    const uint32_t y = std::min(uint32_t(fy * float(r.height())), r.height() - 1);
    const std::string text = session_->visibilityKept()
                                 ? pixelReport(x, y)
                                 : fmt::format("pixel ({}, {})\n(drawing the frame again with its visibility images)", x, y);
    ImGui::SetTooltip("%s", text.c_str());
}

std::string Viewer::pixelReport(uint32_t x, uint32_t y)
{
    frame::FrameRenderer& r = session_->renderer();
    // One texel of the colour and of each V, read again for a new frame, renderer (an edit,
    // another file: its frame count starts again) or pixel only.
    if (!inspected_ || inspectedRenderer_ != &r || inspectedFrame_ != session_->framesRendered() ||
        inspectedAt_ != std::pair{x, y}) {
        inspected_ = r.readPixel(x, y);
        inspectedRenderer_ = &r;
        inspectedFrame_ = session_->framesRendered();
        inspectedAt_ = {x, y};
    }
    std::string text = fmt::format("pixel ({}, {})\ncolour {} {} {}", x, y, inspected_->color[0], inspected_->color[1],
                                   inspected_->color[2]);
    // Against B (its image is of this view, so of this size): both values and their difference.
    const app::FrameImages* b = comparison_.on() && comparison_.current() ? &comparison_.result()->images : nullptr;
    const size_t pixel = size_t(y) * r.width() + x;
    for (size_t l = 0; l < inspected_->visibility.size() && l < session_->config().lights.size(); ++l) {
        const float a = inspected_->visibility[l];
        if (b && l < b->visibility.size() && pixel < b->visibility[l].size()) {
            const float vb = b->visibility[l][pixel];
            text += fmt::format("\nV {}: A {:.5f}  B {:.5f}  dV {:+.5f}", session_->config().lights[l].name, a, vb, a - vb);
        } else {
            text += fmt::format("\nV {} = {:.5f}", session_->config().lights[l].name, a);
        }
    }
    return text;
}

} // namespace penumbra::viewer
