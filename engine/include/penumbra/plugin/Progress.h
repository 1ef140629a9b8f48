#pragma once
// Progress of long host work inside a frame (the reference's tracing: seconds to minutes on
// a CPU), for whoever waits for that frame on another thread — the viewer's second stack
// shows it as a bar. Whoever renders installs a sink on its thread for the frame
// (ProgressScope); a pass that works for long reports from the thread that runs it. No
// sink installed: reporting costs one thread-local read.
#include <atomic>
#include <cstdint>

namespace penumbra::plugin {

struct ProgressSink {
    std::atomic<double> fraction{0.0};  // of the pass reporting now, in [0, 1]
    std::atomic<uint32_t> passes{0};    // passes that started reporting so far
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

} // namespace penumbra::plugin
