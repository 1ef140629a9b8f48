#include "BenchResults.h"

#include "penumbra/metrics/Pareto.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <map>
#include <numeric>

using nlohmann::json;

namespace penumbra::app {
namespace {

// "0.05" for kErrorThresholds[0]: in column names and table headers.
std::string thresholdText(size_t i) { return fmt::format("{}", metrics::kErrorThresholds[i]); }

json timingJson(const TimingSummary& t)
{
    json passes = json::array();
    for (const PassTimes& p : t.passes) {
        passes.push_back({{"name", p.name}, {"host", p.host}, {"gpu_ms", p.gpuMs}, {"cpu_ms", p.cpuMs}});
    }
    return {{"work_ms", t.workMs}, {"work_min_ms", t.workMinMs}, {"work_max_ms", t.workMaxMs},
            {"gpu_ms", t.gpuMs},   {"host_ms", t.hostMs},        {"cpu_ms", t.cpuMs},
            {"wall_ms", t.frameWallMs}, {"passes", std::move(passes)}};
}

json floorJson(const FloorComparison& c)
{
    json passes = json::array();
    for (const PassAgainstFloor& p : c.passes) {
        passes.push_back({{"name", p.name}, {"against", floorDrawName(p.draw)}, {"floor_ms", p.floorMs}, {"multiple", p.multiple}});
    }
    json floorPasses = json::array();
    for (const PassTimes& p : c.floor.passes.passes) floorPasses.push_back({{"name", p.name}, {"gpu_ms", p.gpuMs}});
    return {{"rule", kFloorRule},
            {"shadowed", c.shadowed},
            {"floor_frame_ms", c.floorFrameMs},
            {"frame_multiple", c.frameMultiple},
            {"shadowed_frame_ms", c.floor.shadowedFrameMs},
            {"unshadowed_frame_ms", c.floor.unshadowedFrameMs},
            {"floor_passes", std::move(floorPasses)},
            {"passes", std::move(passes)}};
}

json cullingJson(const std::string& mode, const visibility::CullingStats& s)
{
    json out = {{"mode", mode}};
    for (const CullingFigure& figure : cullingFigures()) {
        if (figure.count)
            out[figure.key] = s.*figure.count;
        else
            out[figure.key] = s.*figure.ms;
    }
    return out;
}

// RFC 4180: a field with a comma, a quote or a line break is quoted, quotes doubled.
std::string csvField(const std::string& text)
{
    if (text.find_first_of(",\"\r\n") == std::string::npos) return text;
    std::string quoted = "\"";
    for (char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
    return quoted + "\"";
}

// The shortest text that reads back to the same double ("0.5", "1e-07").
std::string number(double value) { return fmt::format("{}", value); }

std::vector<std::string> csvHeader()
{
    std::vector<std::string> columns = {"variant",     "label",        "technique",    "technique_label", "context",
                                        "params",      "scene",        "scene_params", "width",           "height",
                                        "light_index", "light",        "technique_ms", "technique_gpu_ms",
                                        "technique_host_ms", "technique_cpu_ms", "frame_gpu_ms", "frame_wall_ms",
                                        "pass_ms", "floor_frame_ms", "frame_floor_multiple", "memory_bytes",
                                        "culling", "casters_drawn", "triangles_drawn",
                                        "culling_queries", "culling_ms"};
    const auto statsColumns = [&](const std::string& prefix) {
        for (const char* figure : {"pixels", "rmse", "mae", "max_abs_error"}) columns.push_back(prefix + figure);
        for (size_t t = 0; t < metrics::kErrorThresholds.size(); ++t) {
            columns.push_back(fmt::format("{}pct_above_{}", prefix, thresholdText(t)));
        }
    };
    statsColumns("");
    columns.push_back("ssim");
    for (size_t r = 0; r < metrics::kRegionCount; ++r) statsColumns(fmt::format("{}_", metrics::regionName(metrics::Region(r))));
    columns.push_back("pareto_front");
    return columns;
}

void appendStats(std::vector<std::string>& fields, const metrics::ErrorStats& s)
{
    fields.insert(fields.end(), {std::to_string(s.pixels), number(s.rmse), number(s.mae), number(s.maxAbsError)});
    for (size_t t = 0; t < metrics::kErrorThresholds.size(); ++t) fields.push_back(number(s.percentAbove(t)));
}

std::vector<std::string> csvRow(const BenchVariant& v, const BenchLight& l)
{
    json passMs = json::object();  // each pass's work: GPU time, or a host pass's CPU time
    for (const PassTimes& p : l.timing.passes) passMs[p.name] = p.host ? p.cpuMs : p.gpuMs;
    std::vector<std::string> fields = {std::to_string(v.index),
                                       v.label,
                                       l.technique,
                                       l.techniqueLabel,
                                       l.contextLabel,
                                       l.params.dump(),
                                       v.scene,
                                       v.sceneParams.dump(),
                                       std::to_string(v.width),
                                       std::to_string(v.height),
                                       std::to_string(l.index),
                                       l.name,
                                       number(l.timing.workMs),
                                       number(l.timing.gpuMs),
                                       number(l.timing.hostMs),
                                       number(l.timing.cpuMs),
                                       number(v.frame.gpuMs),
                                       number(v.frame.frameWallMs),
                                       passMs.dump(),
                                       number(v.floor.floorFrameMs),
                                       number(v.floor.frameMultiple),
                                       std::to_string(l.memoryBytes()),
                                       v.culling,
                                       std::to_string(v.cullingStats.castersDrawn),
                                       std::to_string(v.cullingStats.trianglesDrawn),
                                       std::to_string(v.cullingStats.queriesIssued),
                                       number(v.cullingStats.cameraMs + v.cullingStats.maskMs +
                                              v.cullingStats.casterCullMs)};
    appendStats(fields, l.visibility.all);
    fields.push_back(number(l.visibility.ssim));
    for (const metrics::ErrorStats& region : l.visibility.regions) appendStats(fields, region);
    fields.push_back(l.paretoFront ? "true" : "false");
    return fields;
}

std::string csvLine(const std::vector<std::string>& fields)
{
    std::string line;
    for (size_t i = 0; i < fields.size(); ++i) {
        if (i > 0) line += ',';
        line += csvField(fields[i]);
    }
    // RFC 4180 ends records with CRLF; spreadsheets and csv readers accept it everywhere.
    return line + "\r\n";
}

json figuresJson(const std::vector<plugin::TechniqueFigure>& figures)
{
    json out = json::array();
    for (const plugin::TechniqueFigure& f : figures) out.push_back({{"name", f.name}, {"value", f.value}, {"unit", f.unit}});
    return out;
}

json lightJson(const BenchLight& l)
{
    json memory = json::array();
    for (const graph::TransientMemory& m : l.memory) memory.push_back({{"name", m.name}, {"bytes", m.bytes}});
    return {{"index", l.index},
            {"name", l.name},
            {"technique", l.technique},
            {"params", l.params},
            {"technique_label", l.techniqueLabel},
            {"context", l.contextLabel},
            {"timing", timingJson(l.timing)},
            {"memory", {{"bytes", l.memoryBytes()}, {"resources", std::move(memory)}}},
            {"visibility", metrics::toJson(l.visibility)},
            {"pareto_front", l.paretoFront},
            {"figures", figuresJson(l.figures)}};
}

std::string bytesText(uint64_t bytes)
{
    if (bytes < 1024) return fmt::format("{} B", bytes);
    if (bytes < 1024 * 1024) return fmt::format("{:.1f} KiB", double(bytes) / 1024.0);
    return fmt::format("{:.1f} MiB", double(bytes) / (1024.0 * 1024.0));
}

// A Markdown table cell: a '|' would end it.
std::string cell(const std::string& text)
{
    std::string out;
    for (char c : text) out += c == '|' ? std::string("\\|") : std::string(1, c);
    return out.empty() ? "–" : out;
}

} // namespace

uint64_t BenchLight::memoryBytes() const
{
    return std::accumulate(memory.begin(), memory.end(), uint64_t(0),
                           [](uint64_t sum, const graph::TransientMemory& m) { return sum + m.bytes; });
}

std::vector<TradeoffPanel> tradeoffPanels(const BenchRun& run)
{
    std::vector<TradeoffPanel> panels;
    std::map<std::pair<std::string, size_t>, size_t> byKey;  // (context, light) -> panel
    for (size_t v = 0; v < run.variants.size(); ++v) {
        for (size_t l = 0; l < run.variants[v].lights.size(); ++l) {
            const BenchLight& light = run.variants[v].lights[l];
            const auto [it, added] = byKey.try_emplace({light.contextLabel, light.index}, panels.size());
            if (added) {
                const std::string lightText = fmt::format("light '{}'", light.name);
                panels.push_back({light.contextLabel.empty() ? lightText : light.contextLabel + " · " + lightText, {}});
            }
            panels[it->second].members.push_back({v, l});
        }
    }
    return panels;
}

void markParetoFronts(BenchRun& run)
{
    for (const TradeoffPanel& panel : tradeoffPanels(run)) {
        std::vector<metrics::TradeoffPoint> points;
        for (const TradeoffPanel::Member& m : panel.members) {
            const BenchLight& l = run.variants[m.variant].lights[m.light];
            points.push_back({l.timing.workMs, l.visibility.all.rmse});
        }
        for (size_t i : metrics::paretoFront(points)) {
            const TradeoffPanel::Member& m = panel.members[i];
            run.variants[m.variant].lights[m.light].paretoFront = true;
        }
    }
}

std::string shellCommand(const std::vector<std::string>& command)
{
    std::vector<std::string> words;
    for (const std::string& arg : command) {
        const bool plain = !arg.empty() && std::all_of(arg.begin(), arg.end(), [](unsigned char c) {
            return std::isalnum(c) || std::string_view("-_./=:,+@%").find(char(c)) != std::string_view::npos;
        });
        std::string quoted = "'";
        for (char c : arg) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
        words.push_back(plain ? arg : quoted + "'");
    }
    return fmt::format("{}", fmt::join(words, " "));
}

std::string floorLine(const BenchVariant& v)
{
    std::vector<std::string> passes;
    for (const PassAgainstFloor& p : v.floor.passes) {
        passes.push_back(fmt::format("{} {:.2f} x {}", p.name, p.multiple, floorDrawName(p.draw)));
    }
    return fmt::format("frame {:.1f} ms = {:.2f} x {} floor frame {:.1f} ms; {}", v.frame.workMs, v.floor.frameMultiple,
                       v.floor.shadowed ? "shadowed" : "unshadowed", v.floor.floorFrameMs, fmt::join(passes, ", "));
}

std::string resultsCsv(const BenchRun& run)
{
    std::string text = csvLine(csvHeader());
    for (const BenchVariant& v : run.variants) {
        for (const BenchLight& l : v.lights) text += csvLine(csvRow(v, l));
    }
    return text;
}

json resultsJson(const BenchRun& run)
{
    json variants = json::array();
    for (const BenchVariant& v : run.variants) {
        json choices = json::array();
        for (const config::SweepChoice& c : v.choices) {
            choices.push_back({{"paths", c.paths}, {"value", c.value}, {"label", c.label}});
        }
        json lights = json::array();
        for (const BenchLight& l : v.lights) lights.push_back(lightJson(l));
        variants.push_back({{"index", v.index},
                            {"label", v.label},
                            {"choices", std::move(choices)},
                            {"scene", v.scene},
                            {"scene_params", v.sceneParams},
                            {"width", v.width},
                            {"height", v.height},
                            {"timing", timingJson(v.frame)},
                            {"floor", floorJson(v.floor)},
                            {"culling", cullingJson(v.culling, v.cullingStats)},
                            {"lights", std::move(lights)}});
    }
    return {{"config", run.config},
            {"command", shellCommand(run.command)},
            {"argv", run.command},
            {"date", run.date},
            {"machine", run.machine},
            {"device", run.device},
            {"frames", run.frames},
            {"warmup", run.warmup},
            {"animated", run.animated},
            {"reference", {{"technique", run.reference}, {"params", run.referenceParams}, {"renders", run.referenceRenders}}},
            {"scenes_built", run.scenesBuilt},
            {"variants", std::move(variants)},
            {"warnings", run.warnings}};
}

std::string summaryMarkdown(const BenchRun& run)
{
    std::string md = "# Speed–accuracy trade-off\n\n";
    md += fmt::format("- device: {}, {}, Vulkan {}, driver {}\n", run.device.value("name", "?"), run.device.value("type", "?"),
                      run.device.value("vulkan", "?"), run.device.value("driver", "?"));
    md += fmt::format("- machine: {}, {} hardware threads, {} {}\n", run.machine.value("cpu", "unknown CPU"),
                      run.machine.value("cpu_threads", 0u), run.machine.value("os", "unknown OS"), run.machine.value("arch", ""));
    md += fmt::format("- date: {}\n", run.date);
    md += fmt::format("- frames: {} measured after {} warm-up, per variant{}; times are medians\n", run.frames, run.warmup,
                      run.animated ? ", walking the animation (frame k at k / fps; the errors over every measured "
                                     "frame, each against its own pose's reference)"
                                   : "");
    md += fmt::format("- reference: `{}` `{}`\n\n", run.reference, run.referenceParams.dump());
    md += fmt::format("ms is the time of the light's shadow passes: on the GPU (timestamp queries), and on the CPU "
                      "for host passes; memory is that of those passes' resources: transient ones, and a "
                      "technique's own kept from frame to frame (an adaptive shadow map's atlas); the errors compare the "
                      "light's visibility image with the reference's over the pixels that show geometry the light "
                      "reaches (a spot light: inside its outer cone; penumbra: "
                      "where the reference is above {} and below {}). A ✓ marks the Pareto front: no other variant "
                      "in the same table is both faster and more accurate.\n\n",
                      metrics::kUmbraMaxVisibility, metrics::kLitMinVisibility);
    md += fmt::format("Regenerate with:\n\n```sh\n{}\n```\n", shellCommand(run.command));
    if (!run.notes.empty()) {
        md += "\n## Notes\n\n";
        for (const std::string& note : run.notes) md += note + "\n\n";
        md.pop_back();
    }
    for (const TradeoffPanel& panel : tradeoffPanels(run)) {
        md += fmt::format("\n## {}\n\n", panel.title);
        std::string above, aboveRule;
        for (size_t t = 0; t < metrics::kErrorThresholds.size(); ++t) {
            above += fmt::format("> {} | ", thresholdText(t));
            aboveRule += "---:|";
        }
        md += fmt::format("| technique | variant | ms | memory | RMSE | RMSE penumbra | MAE | max | {}SSIM | front |\n", above);
        md += fmt::format("|---|---|---:|---:|---:|---:|---:|---:|{}---:|:-:|\n", aboveRule);
        std::vector<const BenchLight*> rows;
        for (const TradeoffPanel::Member& m : panel.members) rows.push_back(&run.variants[m.variant].lights[m.light]);
        std::stable_sort(rows.begin(), rows.end(),
                         [](const BenchLight* a, const BenchLight* b) { return a->timing.workMs < b->timing.workMs; });
        for (const BenchLight* l : rows) {
            const metrics::ErrorStats& all = l->visibility.all;
            std::string percents;
            for (size_t t = 0; t < metrics::kErrorThresholds.size(); ++t)
                percents += fmt::format("{:.2f}% | ", all.percentAbove(t));
            md += fmt::format("| {} | {} | {:.3f} | {} | {:.4f} | {:.4f} | {:.4f} | {:.3f} | {}{:.4f} | {} |\n",
                              cell(l->technique), cell(l->techniqueLabel), l->timing.workMs, bytesText(l->memoryBytes()),
                              all.rmse, l->visibility.region(metrics::Region::Penumbra).rmse, all.mae, all.maxAbsError,
                              percents, l->visibility.ssim, l->paretoFront ? "✓" : "");
        }
    }
    std::string figures;
    for (const BenchVariant& v : run.variants)
        for (const BenchLight& l : v.lights) {
            if (l.figures.empty()) continue;
            std::vector<std::string> items;
            for (const plugin::TechniqueFigure& f : l.figures)
                items.push_back(fmt::format("{} {}", f.name, figureValueText(f)));
            figures += fmt::format("| {} | {} | {} | {} |\n", cell(v.label.empty() ? "(no sweep)" : v.label),
                                   cell(l.name), cell(l.technique), cell(fmt::format("{}", fmt::join(items, ", "))));
        }
    if (!figures.empty()) {
        md += "\n## Technique figures\n\nWhat each technique reports of its frames (medians per frame): memory it "
              "used, work it did, what it dropped.\n\n| variant | light | technique | figures |\n|---|---|---|---|\n";
        md += figures;
    }
    md += "\n## Against the floor\n\n";
    md += fmt::format("The frame's passes as multiples of the floor's (the config's scene drawn once forward, "
                      "frame/FloorRenderer.h), measured side by side; {}.\n\n",
                      kFloorRule);
    md += "| variant | frame ms | floor frame ms | x floor | passes (x floor) |\n|---|---:|---:|---:|---|\n";
    for (const BenchVariant& v : run.variants) {
        std::vector<std::string> passes;
        for (const PassAgainstFloor& p : v.floor.passes) passes.push_back(fmt::format("{} {:.2f}", p.name, p.multiple));
        md += fmt::format("| {} | {:.3f} | {:.3f} ({}) | {:.2f} | {} |\n", cell(v.label.empty() ? "(no sweep)" : v.label),
                          v.frame.workMs, v.floor.floorFrameMs, v.floor.shadowed ? "shadowed" : "unshadowed",
                          v.floor.frameMultiple, cell(fmt::format("{}", fmt::join(passes, ", "))));
    }
    if (!run.warnings.empty()) {
        md += "\n## Warnings\n\n";
        for (const std::string& w : run.warnings) md += fmt::format("- {}\n", w);
    }
    return md;
}

} // namespace penumbra::app
