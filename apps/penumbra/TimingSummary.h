#pragma once
// Medians of per-pass timings over measured frames: `render --timings` prints them,
// `bench` records them per variant and per technique.
#include "penumbra/render/FrameRenderer.h"

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra::app {

// The median of `samples` (the mean of the middle two for an even count); 0 for none.
double median(std::vector<double> samples);

struct PassTimes {
    std::string name;
    double gpuMs = 0.0;  // median GPU time (timestamp queries)
    double cpuMs = 0.0;  // median CPU time its callback took to record
};

struct TimingSummary {
    size_t frames = 0;
    std::vector<PassTimes> passes;  // in the order they first ran
    // Per frame, the sum over `passes`; then the median over the frames. A sum's median,
    // not a sum of medians: the figure of one typical frame.
    double gpuMs = 0.0;
    double cpuMs = 0.0;
    double frameWallMs = 0.0;  // median of FrameTimings::frameCpuMs (record, submit, wait)
};

// Summarises the passes whose names start with `prefix` (every pass for ""). A pass
// missing from a frame counts as 0 ms there. With no frames every figure is 0.
TimingSummary summarizeTimings(const std::vector<render::FrameTimings>& frames, std::string_view prefix = "");

// The table `render --timings` prints on stdout.
void printTimings(const TimingSummary& summary);

} // namespace penumbra::app
