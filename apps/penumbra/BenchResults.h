#pragma once
// What `penumbra bench` measured, and the documents it makes of it: results.csv (one row
// per sweep variant × light), results.json (the same, structured, with the machine, the
// device and the command), and the Markdown summary of `--summary`. ParetoPlot.h draws
// the same results.
#include "FloorComparison.h"
#include "TimingSummary.h"

#include "penumbra/config/Config.h"
#include "penumbra/graph/GraphExecutor.h"
#include "penumbra/metrics/ImageComparison.h"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace penumbra::app {

// One light of one variant.
struct BenchLight {
    size_t index = 0;
    std::string name;
    std::string technique;   // the plugin; "unshadowed" when it could not be used
    nlohmann::json params;   // the technique's parameters as resolved; null when unshadowed
    // The variant's sweep choices that set this light's shadow (its technique and
    // parameters), and all the others (scene, light size, other lights): a trade-off
    // plot compares techniques with the context held fixed.
    std::string techniqueLabel;
    std::string contextLabel;
    TimingSummary timing;    // the light's shadow passes (FrameRenderer::shadowPassPrefix)
    std::vector<graph::TransientMemory> memory;  // the transient resources of those passes
    metrics::VisibilityComparison visibility;    // against the reference
    bool paretoFront = false;  // not dominated in (timing.workMs, RMSE) within its panel
    // The technique's own figures (plugin::Technique::figures), medians per frame.
    std::vector<plugin::TechniqueFigure> figures;

    uint64_t memoryBytes() const;
};

struct BenchVariant {
    size_t index = 0;
    std::string label;  // config::SweepVariant::label; empty without a sweep
    std::vector<config::SweepChoice> choices;
    std::string scene;            // each part's generator or glTF file name ("a.glb + box-grid")
    nlohmann::json sceneParams;   // the config's "scene" as configJson writes it (parts, transforms)
    uint32_t width = 0;
    uint32_t height = 0;
    TimingSummary frame;          // every pass of the frame
    FloorComparison floor;        // the frame against the floor of its config
    std::string culling;          // the config's culling mode
    visibility::CullingStats cullingStats;  // medians per frame (render --stats)
    std::vector<BenchLight> lights;
};

struct BenchRun {
    std::string config;
    std::vector<std::string> command;  // argv as given
    std::string date;                  // UTC, ISO 8601
    nlohmann::json machine;            // {"os", "arch", "cpu", "cpu_threads"}
    nlohmann::json device;             // {"name", "type", "vulkan", "driver"}
    uint32_t frames = 0;
    uint32_t warmup = 0;
    bool animated = false;             // --animate: the frames walk the animation
    std::string reference;             // the reference technique
    nlohmann::json referenceParams;
    size_t referenceRenders = 0;       // one per distinct (scene, camera, light) at most
    size_t scenesBuilt = 0;            // one per scene source (config::SceneCache), one per animated variant
    std::vector<BenchVariant> variants;
    std::vector<std::string> warnings;
    std::vector<std::string> notes;    // the config's "notes", for the summary
};

// The lights measured under one context (same scene, light size, ...; same light):
// the points of one trade-off panel.
struct TradeoffPanel {
    std::string title;  // "<context> · light '<name>'", or just the light
    struct Member {
        size_t variant = 0;
        size_t light = 0;
    };
    std::vector<Member> members;  // in sweep order
};

// Panels in order of first appearance.
std::vector<TradeoffPanel> tradeoffPanels(const BenchRun& run);

// Sets BenchLight::paretoFront: the front of each panel over (technique ms, RMSE).
void markParetoFronts(BenchRun& run);

// The shell command that `command` was, quoted where needed ("penumbra bench 'a b.json'").
std::string shellCommand(const std::vector<std::string>& command);

// One line of a variant's frame against the floor: "frame 142.0 ms = 3.09 x shadowed floor
// frame 46.0 ms; gbuffer 3.40 x forward, ...".
std::string floorLine(const BenchVariant& variant);

// results.csv: RFC 4180, a header, one row per variant × light; numbers as the shortest
// text that reads back to the same double. Columns in BenchResults.cpp (kCsvColumns).
std::string resultsCsv(const BenchRun& run);
// results.json.
nlohmann::json resultsJson(const BenchRun& run);
// The Markdown summary: per panel, one table row per technique variant, fastest first.
std::string summaryMarkdown(const BenchRun& run);

} // namespace penumbra::app
