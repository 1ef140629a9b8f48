#pragma once
// What draws the viewer's second stack ("B", Comparison.h): the view the user looks at,
// drawn by other techniques — by default the ray-traced reference — on a worker thread with
// its own device, so that a reference that takes seconds never stalls the window. A
// request replaces the one waiting, and a result of a request that was cancelled is dropped.
#include "FrameCapture.h"  // apps/penumbra: what compare reads back

#include "penumbra/config/Config.h"
#include "penumbra/gpu/Context.h"
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

// The frame in flight: how long it has run and its long passes (the reference's tracing,
// plugin/Progress.h): how many have started and the fraction of the current one; 0
// passes: none reports.
struct DrawerProgress {
    bool busy = false;  // a request is waiting or being drawn
    double seconds = 0.0;
    uint32_t passes = 0;
    double fraction = 0.0;
};

// What draws B: ComparisonWorker; the unit tests give one that answers at once.
class BDrawer {
public:
    virtual ~BDrawer() = default;
    virtual void request(ComparisonRequest request) = 0;
    // Drops the waiting request and the result of the one in flight.
    virtual void cancel() = 0;
    virtual DrawerProgress progress() const = 0;
    // The latest finished result, once.
    virtual std::optional<ComparisonResult> take() = 0;
    // Validation messages of the drawer's device (0 before it exists).
    virtual uint32_t validationMessages() const = 0;
};

class ComparisonWorker final : public BDrawer {
public:
    // The worker's device is made on its thread, at the first request, as `options` says
    // (headless; the viewer's device request and validation), and its plugin registry with
    // `pluginSearchPath` (after a plugin reload: the fresh copies', PluginReloader.h).
    ComparisonWorker(gpu::ContextOptions options, std::vector<std::filesystem::path> pluginSearchPath);
    // Cancels the frame in flight, waits for it and joins the thread.
    ~ComparisonWorker() override;
    ComparisonWorker(const ComparisonWorker&) = delete;
    ComparisonWorker& operator=(const ComparisonWorker&) = delete;

    void request(ComparisonRequest request) override;
    // The frame in flight stops at its next progress poll (the reference's tracing: its
    // next row; plugin/Progress.h).
    void cancel() override;
    DrawerProgress progress() const override;
    std::optional<ComparisonResult> take() override;
    uint32_t validationMessages() const override { return validationMessages_.load(); }

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
