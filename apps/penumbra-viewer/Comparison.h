#pragma once
// The viewer's A/B comparison: the shown stack (A) against a second stack (B) that draws
// the same view with other techniques — by default the ray-traced reference — off the
// window's thread (ComparisonWorker.h). B is asked for once the view has been still for a
// moment, so that a drag does not ask for every step; a result for a view that has moved
// on is not shown. The error of A against B is metrics::compareVisibility per light, as
// `penumbra compare` computes it. Nothing here needs a window: the viewer uploads B's
// image and the difference image when their versions change.
#include "ComparisonWorker.h"

#include "penumbra/config/Config.h"
#include "penumbra/config/Overrides.h"
#include "penumbra/metrics/ImageComparison.h"
#include "penumbra/plugin/PluginRegistry.h"

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra::viewer {

// What B depends on: the scene, camera, lights, size, animation and its time, not the
// shown stack's techniques or culling. Two views with the same key show the same B.
std::string viewKey(const config::RenderConfig& config, float timeS);

// `config` with every light shadowed as `b` says (required: a B that cannot run is an
// error, never an unshadowed image to compare with).
config::RenderConfig withShadows(config::RenderConfig config, const std::vector<config::ShadowSettings>& b);

// Per light of the shown stack (A) against B, over the pixels `penumbra compare` takes
// (app::reachMask: geometry the light reaches), so that the figures are compare's.
std::vector<metrics::VisibilityComparison> compareStacks(const std::vector<std::vector<float>>& a, const app::FrameImages& b,
                                                         const std::vector<config::LightConfig>& lights);

// What the view shows while B is of the view A shows.
enum class CompareView { A, B, Split, Difference };
// "a", "b", "split" or "difference"; nothing for another word.
std::optional<CompareView> parseCompareView(std::string_view word);

class Comparison {
public:
    using Clock = std::chrono::steady_clock;
    // B is asked for once the view has been still this long.
    static constexpr std::chrono::milliseconds kRestBeforeRequest{400};
    // Makes what draws B, with the plugins of this search path (the viewer: a
    // ComparisonWorker on its own device).
    using MakeDrawer = std::function<std::unique_ptr<BDrawer>(const std::vector<std::filesystem::path>& pluginSearchPath)>;

    explicit Comparison(MakeDrawer makeDrawer);

    // B draws every one of `lightCount` lights with `technique`; its drawer is made at the
    // first start. Forgets B's last image.
    void start(const std::string& technique, size_t lightCount, const std::vector<std::filesystem::path>& pluginSearchPath);
    void stop();
    bool on() const { return on_; }

    // B's shadow settings per light. The Compare panel edits them in place and then calls
    // settingsChanged(): B is drawn again.
    std::vector<config::ShadowSettings>& bShadows() { return bShadows_; }
    void settingsChanged();
    // `compare-set`: the parameter on every light B draws with `o.technique`, checked
    // against the plugin's specs. Throws Error naming `where` (no light of B uses it, or a
    // value the plugin refuses); B is unchanged then.
    void setParam(const config::ParamOverride& o, const std::string& where, plugin::PluginRegistry& plugins);
    // After a plugin reload: a new drawer with the fresh copies (B's settings stay), when
    // one was made already (returns whether).
    bool usePlugins(const std::vector<std::filesystem::path>& pluginSearchPath);
    // B's Cancel: the frame in flight stops, and B is not asked for again until the view
    // or B's settings change.
    void cancel();

    // A drew a new frame: its error against B is computed again at the next update.
    void aChanged() { errorsDirty_ = true; }
    // Once a window frame, after A's frame: takes B's finished image, asks for B once the
    // view (`shownView` at `timeS`) has rested, and computes A's errors when A or B changed
    // (`readAVisibility`: A's V per light, read only then). Lights added or removed start
    // B again with its first light's technique. Returns what the status line should say
    // (B failed), or nothing.
    std::string update(const config::RenderConfig& shownView, float timeS, Clock::time_point now,
                       const std::function<std::vector<std::vector<float>>()>& readAVisibility);

    // B is of the view A shows (the last update's).
    bool current() const;
    // A's errors are those against the current B: what `wait-compare` waits for.
    bool ready() const { return current() && !errorsDirty_; }
    // The view shows B's image, the split or the difference in place of A's.
    bool replacesA() const { return on_ && current() && view_ != CompareView::A; }
    bool shows(CompareView view) const { return on_ && current() && view_ == view; }
    // B's image for the current view, or nullptr.
    const ComparisonResult* result() const { return current() ? &*result_ : nullptr; }
    // Why B failed for the current view (empty: it did not).
    const std::string& bError() const { return bError_; }
    // A's error against B per light, of the current B.
    const std::vector<metrics::VisibilityComparison>& errors() const { return errors_; }
    DrawerProgress progress() const { return drawer_ ? drawer_->progress() : DrawerProgress{}; }
    // Of every drawer made (replaced ones included).
    uint32_t validationMessages() const;

    CompareView view() const { return view_; }
    void setView(CompareView view) { view_ = view; }
    float splitAt() const { return splitAt_; }  // the split's place, a fraction of the width
    void setSplitAt(float fraction);
    // The difference image: |V_A - V_B| of one light, in false colour over [0, scale].
    int differenceLight() const { return differenceLight_; }
    float differenceScale() const { return differenceScale_; }
    void setDifference(int light, float scale);
    const std::vector<uint8_t>& differenceRgba() const { return differenceRgba_; }
    // Move on whenever B's image or the difference image changes: the viewer uploads them.
    uint64_t bImageVersion() const { return bImageVersion_; }
    uint64_t differenceVersion() const { return differenceVersion_; }

private:
    void forgetB();
    void updateDifferenceImage();

    MakeDrawer makeDrawer_;
    std::unique_ptr<BDrawer> drawer_;
    std::vector<std::filesystem::path> pluginSearchPath_;
    uint32_t retiredValidationMessages_ = 0;  // of drawers replaced after a plugin reload
    bool on_ = false;
    std::vector<config::ShadowSettings> bShadows_;
    std::optional<ComparisonResult> result_;
    std::string bError_;
    std::vector<config::LightConfig> lights_;   // the shown view's, at the last update
    std::vector<std::vector<float>> aVisibility_;  // A's V when the errors were computed
    std::vector<metrics::VisibilityComparison> errors_;
    bool errorsDirty_ = false;
    std::string viewKey_, requestedKey_;  // the view A shows; the view B was last asked for
    Clock::time_point stillSince_{};
    CompareView view_ = CompareView::A;
    float splitAt_ = 0.5f;
    int differenceLight_ = 0;
    float differenceScale_ = 0.5f;
    std::vector<uint8_t> differenceRgba_;
    uint64_t bImageVersion_ = 0, differenceVersion_ = 0;
};

} // namespace penumbra::viewer
