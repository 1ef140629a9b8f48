#pragma once
// Progress of long host work inside a frame (the reference's tracing: seconds to minutes on
// a CPU), for whoever waits for that frame — the viewer shows it as a bar, for its second
// stack on another thread and for the frame it shows on its own — and a way to stop it.
// Whoever renders installs a sink on its thread for the frame (ProgressScope); a pass that
// works for long reports from the thread that runs it and polls whether it should stop.
// No sink installed: reporting costs one thread-local read.
//
// Plugins call only the functions below; the sink is the engine's and its caller's.
#include <atomic>
#include <cstdint>
#include <functional>

namespace penumbra::plugin {

struct ProgressSink {
    std::atomic<double> fraction{0.0};  // of the pass reporting now, in [0, 1]
    std::atomic<uint32_t> passes{0};    // passes that started reporting so far
    // Set by whoever waits (any thread): the frame should stop. A pass that polls
    // progressCancelled() stops at its next unit of work and throws penumbra::Error.
    std::atomic<bool> cancelled{false};
    // Called by every report, on the thread that renders (a pass reports every few tens of
    // milliseconds): a window drawn by that thread shows the progress meanwhile. Set it
    // before the scope is installed.
    std::function<void()> onReport;
};

// Makes `sink` the calling thread's while it lives (the previous one comes back after).
class ProgressScope {
public:
    explicit ProgressScope(ProgressSink& sink);
    ~ProgressScope();
    ProgressScope(const ProgressScope&) = delete;
    ProgressScope& operator=(const ProgressScope&) = delete;

private:
    ProgressSink* previous_;
};

// Whether someone on this thread waits for progress (a pass may then poll its workers).
bool progressWanted();
// A pass starts its long work (fraction 0), then reports `done` of `total` units of it
// (total 0 counts as done); both from the thread that runs the pass.
void startProgress();
void reportProgress(uint64_t done, uint64_t total);
// Whether whoever waits asked the frame to stop (ProgressSink::cancelled); false without
// a sink. A pass that sees it stops early and throws penumbra::Error (never a partial
// result as if it were whole).
bool progressCancelled();

} // namespace penumbra::plugin
