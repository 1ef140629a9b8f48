#include "TimingSummary.h"

#include "FloorComparison.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>

namespace penumbra::app {

double median(std::vector<double> samples)
{
    if (samples.empty()) return 0.0;
    std::sort(samples.begin(), samples.end());
    const size_t n = samples.size();
    return n % 2 ? samples[n / 2] : 0.5 * (samples[n / 2 - 1] + samples[n / 2]);
}

TimingSummary summarizeTimings(const std::vector<frame::FrameTimings>& frames, std::string_view prefix,
                               const std::set<std::string, std::less<>>& hostPasses)
{
    struct Samples {
        std::vector<double> gpu, cpu;
        size_t kept = 0;
    };
    std::vector<std::string> order;
    std::map<std::string, Samples, std::less<>> samples;
    std::vector<double> gpuSums, cpuSums, hostSums, workSums, wall;
    for (const frame::FrameTimings& frame : frames) {
        double gpu = 0.0, cpu = 0.0, host = 0.0;
        for (const frame::PassTiming& pass : frame.passes) {
            if (pass.name.compare(0, prefix.size(), prefix) != 0) continue;
            if (!samples.count(pass.name)) order.push_back(pass.name);
            samples[pass.name].gpu.push_back(pass.gpuMs);
            samples[pass.name].cpu.push_back(pass.cpuMs);
            if (pass.kept) ++samples[pass.name].kept;
            gpu += pass.gpuMs;
            cpu += pass.cpuMs;
            if (hostPasses.count(pass.name)) host += pass.cpuMs;
        }
        gpuSums.push_back(gpu);
        cpuSums.push_back(cpu);
        hostSums.push_back(host);
        workSums.push_back(gpu + host);
        wall.push_back(frame.frameCpuMs);
    }
    TimingSummary summary;
    summary.frames = frames.size();
    for (const std::string& name : order) {
        // A pass that ran in only some frames (a graph rebuilt mid-run) took 0 ms in the others.
        Samples& s = samples[name];
        s.gpu.resize(frames.size(), 0.0);
        s.cpu.resize(frames.size(), 0.0);
        summary.passes.push_back({name, hostPasses.count(name) > 0, median(s.gpu), median(s.cpu), s.kept});
    }
    summary.gpuMs = median(std::move(gpuSums));
    summary.cpuMs = median(std::move(cpuSums));
    summary.hostMs = median(std::move(hostSums));
    if (!workSums.empty()) {
        const auto [least, most] = std::minmax_element(workSums.begin(), workSums.end());
        summary.workMinMs = *least;
        summary.workMaxMs = *most;
    }
    summary.workMs = median(std::move(workSums));
    summary.frameWallMs = median(std::move(wall));
    return summary;
}

namespace {

// "kept in 59 of 60 frames" for a pass that kept an earlier frame's results, else "".
std::string keptText(const PassTimes& pass, size_t frames)
{
    return pass.keptFrames == 0 ? std::string() : fmt::format("  kept in {} of {} frames", pass.keptFrames, frames);
}

} // namespace

void printTimings(const TimingSummary& summary, uint32_t warmup, const FloorComparison* floor)
{
    fmt::print("timings: median of {} frame(s) after {} warm-up\n", summary.frames, warmup);
    if (!floor) {
        fmt::print("  {:<34} {:>10} {:>12}\n", "pass", "GPU ms", "CPU ms");
        for (const PassTimes& pass : summary.passes)
            fmt::print("  {:<34} {:>10.3f} {:>12.3f}{}\n", pass.name, pass.gpuMs, pass.cpuMs, keptText(pass, summary.frames));
        fmt::print("  {:<34} {:>10.3f}\n", "sum of passes (GPU)", summary.gpuMs);
        fmt::print("  {:<34} {:>10.3f}\n", "frame wall clock (CPU)", summary.frameWallMs);
        return;
    }
    fmt::print("  {}\n", kFloorRule);
    fmt::print("  {:<34} {:>10} {:>12} {:>9}  {}\n", "pass", "GPU ms", "CPU ms", "x floor", "against");
    for (size_t i = 0; i < summary.passes.size(); ++i) {
        const PassTimes& pass = summary.passes[i];
        const PassAgainstFloor& a = floor->passes.at(i);
        fmt::print("  {:<34} {:>10.3f} {:>12.3f} {:>9.2f}  {}{}\n", pass.name, pass.gpuMs, pass.cpuMs, a.multiple,
                   floorDrawName(a.draw), keptText(pass, summary.frames));
    }
    fmt::print("  {:<34} {:>10.3f} {:>12} {:>9.2f}  {} floor frame\n", "sum of passes (GPU)", summary.gpuMs, "",
               floor->frameMultiple, floor->shadowed ? "shadowed" : "unshadowed");
    fmt::print("  {:<34} {:>10.3f}\n", "frame wall clock (CPU)", summary.frameWallMs);
    printFloor(*floor);
}

std::span<const CullingFigure> cullingFigures()
{
    using S = visibility::CullingStats;
    static const CullingFigure figures[] = {
        {"receivers", "receivers (instances the camera sees)", &S::receivers},
        {"camera_fell_back", "camera culled to its frustum only", &S::cameraFellBack},
        {"views", "light views culled", &S::views},
        {"views_fell_back", "of which to their frustum only", &S::viewsFellBack},
        {"casters_drawn", "casters drawn (instance draws)", &S::castersDrawn},
        {"triangles_drawn", "triangles drawn in caster passes", &S::trianglesDrawn},
        {"map_texels_rendered", "map texels rendered (render areas)", &S::mapTexelsRendered},
        {"masks_on_host", "receiver masks scattered on the host", &S::masksOnHost},
        {"nodes_visited", "BVH nodes visited", &S::nodesVisited},
        {"queries", "occlusion queries issued", &S::queriesIssued},
        {"query_rounds", "query rounds (submissions waited for)", &S::queryRounds},
        {"mask_rejected", "nodes culled by the mask, no query", &S::maskRejected},
        {"floor_rejected", "nodes behind the receivers, no query", &S::floorRejected},
        {"camera_ms", "camera culling ms", nullptr, &S::cameraMs},
        {"mask_ms", "receiver masks ms", nullptr, &S::maskMs},
        {"caster_cull_ms", "caster culling ms", nullptr, &S::casterCullMs},
    };
    return figures;
}

visibility::CullingStats medianCulling(const std::vector<frame::FrameTimings>& frames)
{
    visibility::CullingStats s;
    for (const CullingFigure& figure : cullingFigures()) {
        std::vector<double> v;
        for (const frame::FrameTimings& f : frames)
            v.push_back(figure.count ? double(f.culling.*figure.count) : f.culling.*figure.ms);
        const double m = median(std::move(v));
        if (figure.count)
            s.*figure.count = uint64_t(m);
        else
            s.*figure.ms = m;
    }
    return s;
}

void printCulling(const visibility::CullingStats& s, std::string_view mode)
{
    fmt::print("culling {} (median per frame)\n", mode);
    for (const CullingFigure& figure : cullingFigures()) {
        if (figure.count)
            fmt::print("  {:<39}{}\n", figure.label, s.*figure.count);
        else
            fmt::print("  {:<39}{:.2f}\n", figure.label, s.*figure.ms);
    }
}

std::vector<std::vector<plugin::TechniqueFigure>> medianTechniqueFigures(const std::vector<frame::FrameTimings>& frames)
{
    std::vector<std::vector<plugin::TechniqueFigure>> out;
    if (frames.empty()) return out;
    out = frames.back().techniques;
    for (size_t light = 0; light < out.size(); ++light) {
        for (plugin::TechniqueFigure& figure : out[light]) {
            std::vector<double> v;
            for (const frame::FrameTimings& f : frames) {
                double value = 0.0;
                if (light < f.techniques.size())
                    for (const plugin::TechniqueFigure& g : f.techniques[light])
                        if (g.name == figure.name) value = g.value;
                v.push_back(value);
            }
            figure.value = median(std::move(v));
        }
    }
    return out;
}

std::string figureValueText(const plugin::TechniqueFigure& f)
{
    const bool whole = f.value == std::floor(f.value) && std::abs(f.value) < 1e15;
    return fmt::format("{}{}{}", whole ? fmt::format("{:.0f}", f.value) : fmt::format("{:.3f}", f.value),
                       f.unit.empty() ? "" : " ", f.unit);
}

std::string techniqueFiguresText(const std::vector<std::vector<plugin::TechniqueFigure>>& figures,
                                 const std::vector<std::string>& techniques)
{
    std::string text;
    for (size_t light = 0; light < figures.size(); ++light) {
        if (figures[light].empty()) continue;
        text += fmt::format("light {} ({}) figures (median per frame)\n", light,
                            light < techniques.size() ? techniques[light] : std::string("?"));
        for (const plugin::TechniqueFigure& f : figures[light])
            text += fmt::format("  {:<39}{}\n", f.name, figureValueText(f));
    }
    return text;
}

std::string lightFatesText(const std::vector<frame::FrameTimings>& frames, const std::vector<config::LightConfig>& lightConfigs)
{
    if (frames.empty() || frames.back().lights.empty()) return {};
    const size_t lights = frames.back().lights.size();
    struct Count {
        size_t frames[3] = {0, 0, 0};  // by LightFate
        const frame::LightDecision* last = nullptr;  // the last frame it was culled or demoted
    };
    std::vector<Count> counts(lights);
    for (const frame::FrameTimings& f : frames) {
        for (size_t l = 0; l < std::min(lights, f.lights.size()); ++l) {
            ++counts[l].frames[size_t(f.lights[l].fate)];
            if (!f.lights[l].why.empty()) counts[l].last = &f.lights[l];
        }
    }
    // The last frame's fates, then who did not draw its shadows in some frame.
    size_t last[3] = {0, 0, 0};
    for (const frame::LightDecision& d : frames.back().lights) ++last[size_t(d.fate)];
    std::string text = fmt::format("lights (last frame): {} shadowed, {} unshadowed, {} culled (of {})\n",
                                   last[size_t(frame::LightFate::Shadowed)], last[size_t(frame::LightFate::Unshadowed)],
                                   last[size_t(frame::LightFate::Culled)], lights);
    for (size_t l = 0; l < lights; ++l) {
        if (!counts[l].last) continue;
        const std::string name = l < lightConfigs.size() ? lightConfigs[l].name : std::string();
        text += fmt::format("  light {} ('{}'): {} in {} of {} frame(s): {}\n", l, name,
                            frame::lightFateName(counts[l].last->fate), counts[l].frames[size_t(counts[l].last->fate)],
                            frames.size(), counts[l].last->why);
    }
    return text;
}

} // namespace penumbra::app
