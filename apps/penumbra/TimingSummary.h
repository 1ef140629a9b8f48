#pragma once
// Medians of per-pass timings over measured frames: `render --timings` prints them,
// `bench` records them per variant and per technique.
#include "penumbra/frame/FrameRenderer.h"

#include <cstddef>
#include <set>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra::app {

struct FloorComparison;  // FloorComparison.h

// The median of `samples` (the mean of the middle two for an even count); 0 for none.
double median(std::vector<double> samples);

struct PassTimes {
    std::string name;
    bool host = false;   // a host pass: its work is cpuMs, it has no GPU time
    double gpuMs = 0.0;  // median GPU time (timestamp queries)
    double cpuMs = 0.0;  // median CPU time of its callback: recording, or a host pass's work
    size_t keptFrames = 0;  // frames that kept its results from an earlier frame (it ran in none of them: 0 ms)
};

struct TimingSummary {
    size_t frames = 0;
    std::vector<PassTimes> passes;  // in the order they first ran
    // Per frame, the sum over `passes`; then the median over the frames. A sum's median,
    // not a sum of medians: the figure of one typical frame.
    double gpuMs = 0.0;   // GPU time (host passes have none)
    double cpuMs = 0.0;   // callbacks: recording, and host passes' work
    double hostMs = 0.0;  // host passes' work alone
    // What the frame waits for: GPU passes on the GPU plus host passes on the CPU. The
    // cost of a technique whatever runs where; gpuMs when it has no host pass.
    double workMs = 0.0;
    // The least and the most work of one frame over the frames: the spread behind workMs's
    // median, which a few frames leave uncertain.
    double workMinMs = 0.0;
    double workMaxMs = 0.0;
    double frameWallMs = 0.0;  // median of FrameTimings::frameCpuMs: the whole frame, wall clock
};

// Summarises the passes whose names start with `prefix` (every pass for ""); those named
// in `hostPasses` are host passes (graph::QueueKind::Host). A pass missing from a frame
// counts as 0 ms there. With no frames every figure is 0.
TimingSummary summarizeTimings(const std::vector<frame::FrameTimings>& frames, std::string_view prefix = "",
                               const std::set<std::string, std::less<>>& hostPasses = {});

// The table `render --timings` prints on stdout, with each pass's multiple of the floor
// (FloorComparison.h) when `floor` is given.
void printTimings(const TimingSummary& summary, uint32_t warmup, const FloorComparison* floor = nullptr);

// One figure of visibility::CullingStats: its key in bench's results.json, its label in
// `render --stats`, and its member (a count, or a time in ms).
struct CullingFigure {
    const char* key;
    const char* label;
    uint64_t visibility::CullingStats::*count = nullptr;
    double visibility::CullingStats::*ms = nullptr;
};
// Every figure, in the order `render --stats` prints them: the one list that the median,
// the printout and results.json follow.
std::span<const CullingFigure> cullingFigures();

// Medians over the frames of the visibility service's figures (visibility::CullingStats),
// each taken separately.
visibility::CullingStats medianCulling(const std::vector<frame::FrameTimings>& frames);

// The lines `render --stats` prints on stdout.
void printCulling(const visibility::CullingStats& stats, std::string_view mode);

// Per light, the median over the frames of each figure its technique reported
// (plugin::Technique::figures), by name; a figure missing from a frame counts as 0 there.
std::vector<std::vector<plugin::TechniqueFigure>> medianTechniqueFigures(const std::vector<frame::FrameTimings>& frames);
// One figure's value and unit as the printouts write it: "1622306", "37.132 MiB" (whole
// values without decimals, others with three).
std::string figureValueText(const plugin::TechniqueFigure& figure);
// What `render --stats` and `graph` print of them: per light with figures, a heading
// naming the light and its technique (`techniques`: the renderer's techniqueName), then
// one line per figure.
std::string techniqueFiguresText(const std::vector<std::vector<plugin::TechniqueFigure>>& figures,
                                 const std::vector<std::string>& techniques);

// Which lights did not draw their shadows over the frames and why (frame/LightInfluence.h):
// "lights: 1 shadowed, 2 culled over 3" then, per light culled or unshadowed by
// max_shadowed_lights in any frame, in how many frames and the last frame's reason, named
// as in `lightConfigs` (the config's). What `render --timings`, `--stats` and `graph` print.
std::string lightFatesText(const std::vector<frame::FrameTimings>& frames, const std::vector<config::LightConfig>& lightConfigs);

} // namespace penumbra::app
