#pragma once
// The viewer's second stack ("B"): the view the user looks at, drawn by other techniques
// — by default the ray-traced reference — on a worker thread with its own device, so that
// a reference that takes seconds never stalls the window. The window asks for B once the
// view has been still for a moment; a request replaces the one waiting, and a result for a
// view that has moved on (or was cancelled) is dropped. The error of the shown stack
// against B is metrics::compareVisibility per light, as `penumbra compare` computes it.
#include "FrameCapture.h"  // apps/penumbra: what compare reads back

#include "penumbra/config/Config.h"
#include "penumbra/gpu/Context.h"
#include "penumbra/metrics/ImageComparison.h"
#include "penumbra/plugin/Progress.h"

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <filesystem>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace penumbra::viewer {

// What B draws, and for which view.
struct ComparisonRequest {
    config::RenderConfig config;  // the view's config (rest pose) with B's shadow settings on every light
    float timeS = 0.0f;           // the animation time A shows: B is posed the same
    std::string viewKey;          // viewKey() of the view it was asked for
};

struct ComparisonResult {
    std::string viewKey;
    app::FrameImages images;  // B's frame as the metrics read it
    double seconds = 0.0;
    std::string error;  // non-empty: B could not be drawn (the message)
};

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

class ComparisonWorker {
public:
    // The worker's device is made on its thread, at the first request, as `options` says
    // (headless; the viewer's device request and validation), and its plugin registry with
    // `pluginSearchPath` (after a plugin reload: the fresh copies', PluginReloader.h).
    ComparisonWorker(gpu::ContextOptions options, std::vector<std::filesystem::path> pluginSearchPath);
    // Cancels the frame in flight, waits for it and joins the thread.
    ~ComparisonWorker();
    ComparisonWorker(const ComparisonWorker&) = delete;
    ComparisonWorker& operator=(const ComparisonWorker&) = delete;

    void request(ComparisonRequest request);
    // Drops the waiting request and the result of the one in flight, which stops at its
    // next progress poll (the reference's tracing: its next row; plugin/Progress.h).
    void cancel();
    // A request is waiting or being drawn; for how long the current one has run.
    bool busy() const { return busy_.load(); }
    double busySeconds() const;
    // The frame in flight's long passes (the reference's tracing, plugin/Progress.h): how
    // many have started and the fraction of the current one; 0 passes: none reports.
    uint32_t progressPasses() const { return progress_.passes.load(); }
    double progressFraction() const { return progress_.fraction.load(); }
    // The latest finished result, once.
    std::optional<ComparisonResult> take();
    // Validation messages of the worker's device (0 before it exists).
    uint32_t validationMessages() const { return validationMessages_.load(); }

private:
    void run();

    gpu::ContextOptions options_;
    std::vector<std::filesystem::path> pluginSearchPath_;
    std::thread thread_;
    mutable std::mutex mutex_;
    std::condition_variable wake_;
    std::optional<ComparisonRequest> waiting_;
    std::optional<ComparisonResult> done_;
    bool stop_ = false;
    uint64_t generation_ = 0;  // cancel() moves it on: a result of an older one is dropped
    std::atomic<bool> busy_{false};
    std::atomic<int64_t> startedNs_{0};
    std::atomic<uint32_t> validationMessages_{0};
    plugin::ProgressSink progress_;
};

} // namespace penumbra::viewer
