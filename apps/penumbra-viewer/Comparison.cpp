#include "Comparison.h"

#include "penumbra/core/Error.h"
#include "penumbra/core/ShortText.h"
#include "penumbra/metrics/DebugImage.h"
#include "penumbra/metrics/Images.h"
#include "penumbra/plugin/Params.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>

namespace penumbra::viewer {

std::string viewKey(const config::RenderConfig& config, float timeS)
{
    config::RenderConfig view = config;
    for (config::LightConfig& light : view.lights) light.shadow = {};
    view.culling = config::CullingMode::None;
    view.shadowFocus = false;
    view.frames = 1;
    view.notes.clear();
    return fmt::format("{} at {}", config::configJson(view, "/").dump(), config::animated(view) ? timeS : 0.0f);
}

config::RenderConfig withShadows(config::RenderConfig config, const std::vector<config::ShadowSettings>& b)
{
    for (size_t i = 0; i < config.lights.size() && i < b.size(); ++i) {
        config.lights[i].shadow = b[i];
        config.lights[i].shadow.required = true;
    }
    return config;
}

std::vector<metrics::VisibilityComparison> compareStacks(const std::vector<std::vector<float>>& a, const app::FrameImages& b,
                                                         const std::vector<config::LightConfig>& lights)
{
    std::vector<metrics::VisibilityComparison> out;
    for (size_t l = 0; l < a.size() && l < b.visibility.size() && l < lights.size(); ++l) {
        const metrics::PixelMask reaches = app::reachMask(lights[l].light, b.width, b.height, b.positions);
        out.push_back(metrics::compareVisibility({b.width, b.height, a[l]}, {b.width, b.height, b.visibility[l]}, &reaches));
    }
    return out;
}

std::optional<CompareView> parseCompareView(std::string_view word)
{
    if (word == "a") return CompareView::A;
    if (word == "b") return CompareView::B;
    if (word == "split") return CompareView::Split;
    if (word == "difference") return CompareView::Difference;
    return std::nullopt;
}

Comparison::Comparison(MakeDrawer makeDrawer) : makeDrawer_(std::move(makeDrawer)) {}

void Comparison::start(const std::string& technique, size_t lightCount, const std::vector<std::filesystem::path>& pluginSearchPath)
{
    if (!drawer_) {
        pluginSearchPath_ = pluginSearchPath;
        drawer_ = makeDrawer_(pluginSearchPath_);
    }
    on_ = true;
    bShadows_.assign(lightCount, {});
    for (config::ShadowSettings& b : bShadows_) {
        b.technique = technique;
        b.required = true;
        // The reference's 256 rays a pixel take a minute at 1280 x 720 on a CPU: 16 for a
        // first look (raise it in the panel).
        if (technique == "reference") b.setParam("samples", 16, "viewer: B reference.samples");
    }
    drawer_->cancel();
    forgetB();
}

void Comparison::stop()
{
    on_ = false;
    if (drawer_) drawer_->cancel();
}

void Comparison::settingsChanged()
{
    result_.reset();
    requestedKey_.clear();
    if (drawer_) drawer_->cancel();
}

void Comparison::setParam(const config::ParamOverride& o, const std::string& where, plugin::PluginRegistry& plugins)
{
    std::vector<config::ShadowSettings> changed = bShadows_;
    bool used = false;
    for (config::ShadowSettings& b : changed) {
        if (b.technique != o.technique) continue;
        b.setParam(o.param, o.value, fmt::format("{}: compare-set {}.{}", where, o.technique, o.param));
        plugin::resolveParams(plugins.load(b.technique), b);  // throws naming where
        used = true;
    }
    if (!used) {
        throw Error(fmt::format("{}: compare-set: B uses no \"{}\" (compare TECHNIQUE first)", where, core::shortText(o.technique)));
    }
    bShadows_ = std::move(changed);
    settingsChanged();
}

bool Comparison::usePlugins(const std::vector<std::filesystem::path>& pluginSearchPath)
{
    pluginSearchPath_ = pluginSearchPath;
    if (!drawer_) return false;
    retiredValidationMessages_ += drawer_->validationMessages();
    drawer_ = makeDrawer_(pluginSearchPath_);
    forgetB();
    return true;
}

void Comparison::cancel()
{
    if (drawer_) drawer_->cancel();
    requestedKey_ = viewKey_;
}

// B's last image, error and view: asked for again once the view rests.
void Comparison::forgetB()
{
    result_.reset();
    bError_.clear();
    requestedKey_.clear();
    viewKey_.clear();
}

bool Comparison::current() const { return result_ && !viewKey_.empty() && result_->viewKey == viewKey_; }

uint32_t Comparison::validationMessages() const
{
    return retiredValidationMessages_ + (drawer_ ? drawer_->validationMessages() : 0);
}

std::string Comparison::update(const config::RenderConfig& shownView, float timeS, Clock::time_point now,
                               const std::function<std::vector<std::vector<float>>()>& readAVisibility)
{
    if (!on_ || !drawer_) return {};
    std::string notice;
    if (bShadows_.size() != shownView.lights.size()) {
        start(bShadows_.empty() ? "reference" : bShadows_.front().technique, shownView.lights.size(), pluginSearchPath_);
    }
    lights_ = shownView.lights;
    const std::string key = viewKey(shownView, timeS);
    if (key != viewKey_) {
        viewKey_ = key;
        stillSince_ = now;
        bError_.clear();
    }
    if (std::optional<ComparisonResult> r = drawer_->take()) {
        if (!r->error.empty()) {
            if (r->viewKey == key) bError_ = r->error;
            notice = "B: " + r->error;
        } else {
            result_ = std::move(*r);
            ++bImageVersion_;
            errorsDirty_ = true;
            spdlog::info("B drawn in {:.2f} s", result_->seconds);
        }
    }
    // Asked for once the view has rested: not for every step of a drag.
    if (!current() && requestedKey_ != key && now - stillSince_ >= kRestBeforeRequest) {
        drawer_->request({withShadows(shownView, bShadows_), timeS, key});
        requestedKey_ = key;
    }
    if (errorsDirty_ && current()) {
        aVisibility_ = readAVisibility();
        errors_ = compareStacks(aVisibility_, result_->images, lights_);
        updateDifferenceImage();
        errorsDirty_ = false;
    }
    return notice;
}

void Comparison::setSplitAt(float fraction) { splitAt_ = std::clamp(fraction, 0.0f, 1.0f); }

void Comparison::setDifference(int light, float scale)
{
    differenceLight_ = light;
    differenceScale_ = scale;
    updateDifferenceImage();
}

// |V_A - V_B| of one light, in false colour over [0, scale]; pixels not compared 0.
void Comparison::updateDifferenceImage()
{
    if (!current() || aVisibility_.empty() || lights_.empty()) return;
    const app::FrameImages& b = result_->images;
    const size_t l = size_t(std::clamp(differenceLight_, 0, int(std::min(aVisibility_.size(), lights_.size())) - 1));
    const metrics::PixelMask mask = app::reachMask(lights_[l].light, b.width, b.height, b.positions);
    metrics::DebugImageValues diff;
    diff.width = b.width;
    diff.height = b.height;
    diff.values.resize(size_t(diff.width) * diff.height);
    for (size_t i = 0; i < diff.values.size(); ++i) {
        diff.values[i] = mask.covered[i] ? std::abs(aVisibility_[l][i] - b.visibility[l][i]) : 0.0f;
    }
    // A scale of 0 would map every difference to the top of the ramp.
    const double scale = std::max(double(differenceScale_), 1e-6);
    differenceRgba_ = metrics::debugImageRgba(diff, metrics::DebugMapping::FalseColor, {0.0, scale});
    ++differenceVersion_;
}

} // namespace penumbra::viewer
