#include "TimingSummary.h"

#include <fmt/format.h>

#include <algorithm>
#include <map>

namespace penumbra::app {

double median(std::vector<double> samples)
{
    if (samples.empty()) return 0.0;
    std::sort(samples.begin(), samples.end());
    const size_t n = samples.size();
    return n % 2 ? samples[n / 2] : 0.5 * (samples[n / 2 - 1] + samples[n / 2]);
}

TimingSummary summarizeTimings(const std::vector<render::FrameTimings>& frames, std::string_view prefix,
                               const std::set<std::string, std::less<>>& hostPasses)
{
    struct Samples {
        std::vector<double> gpu, cpu;
    };
    std::vector<std::string> order;
    std::map<std::string, Samples, std::less<>> samples;
    std::vector<double> gpuSums, cpuSums, hostSums, workSums, wall;
    for (const render::FrameTimings& frame : frames) {
        double gpu = 0.0, cpu = 0.0, host = 0.0;
        for (const render::PassTiming& pass : frame.passes) {
            if (pass.name.compare(0, prefix.size(), prefix) != 0) continue;
            if (!samples.count(pass.name)) order.push_back(pass.name);
            samples[pass.name].gpu.push_back(pass.gpuMs);
            samples[pass.name].cpu.push_back(pass.cpuMs);
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
        summary.passes.push_back({name, hostPasses.count(name) > 0, median(s.gpu), median(s.cpu)});
    }
    summary.gpuMs = median(std::move(gpuSums));
    summary.cpuMs = median(std::move(cpuSums));
    summary.hostMs = median(std::move(hostSums));
    summary.workMs = median(std::move(workSums));
    summary.frameWallMs = median(std::move(wall));
    return summary;
}

void printTimings(const TimingSummary& summary)
{
    fmt::print("timings: median of {} frame(s)\n", summary.frames);
    fmt::print("  {:<28} {:>10} {:>12}\n", "pass", "GPU ms", "CPU ms");
    for (const PassTimes& pass : summary.passes) fmt::print("  {:<28} {:>10.3f} {:>12.3f}\n", pass.name, pass.gpuMs, pass.cpuMs);
    fmt::print("  {:<28} {:>10.3f}\n", "sum of passes (GPU)", summary.gpuMs);
    fmt::print("  {:<28} {:>10.3f}\n", "frame wall clock (CPU)", summary.frameWallMs);
}

render::CullingStats medianCulling(const std::vector<render::FrameTimings>& frames)
{
    const auto med = [&](auto field) {
        std::vector<double> v;
        for (const render::FrameTimings& f : frames) v.push_back(double(f.culling.*field));
        return median(std::move(v));
    };
    render::CullingStats s;
    s.nodesVisited = uint64_t(med(&render::CullingStats::nodesVisited));
    s.queriesIssued = uint64_t(med(&render::CullingStats::queriesIssued));
    s.queryRounds = uint64_t(med(&render::CullingStats::queryRounds));
    s.maskRejected = uint64_t(med(&render::CullingStats::maskRejected));
    s.receivers = uint64_t(med(&render::CullingStats::receivers));
    s.cameraFellBack = uint64_t(med(&render::CullingStats::cameraFellBack));
    s.views = uint64_t(med(&render::CullingStats::views));
    s.viewsFellBack = uint64_t(med(&render::CullingStats::viewsFellBack));
    s.castersDrawn = uint64_t(med(&render::CullingStats::castersDrawn));
    s.trianglesDrawn = uint64_t(med(&render::CullingStats::trianglesDrawn));
    s.cameraMs = med(&render::CullingStats::cameraMs);
    s.maskMs = med(&render::CullingStats::maskMs);
    s.casterCullMs = med(&render::CullingStats::casterCullMs);
    return s;
}

void printCulling(const render::CullingStats& s, std::string_view mode)
{
    fmt::print("culling {} (median per frame)\n", mode);
    fmt::print("  receivers (instances the camera sees)  {}\n", s.receivers);
    fmt::print("  camera culled to its frustum only      {}\n", s.cameraFellBack);
    fmt::print("  light views culled                     {}\n", s.views);
    fmt::print("  of which to their frustum only         {}\n", s.viewsFellBack);
    fmt::print("  casters drawn (instance draws)         {}\n", s.castersDrawn);
    fmt::print("  triangles drawn in caster passes       {}\n", s.trianglesDrawn);
    fmt::print("  BVH nodes visited                      {}\n", s.nodesVisited);
    fmt::print("  occlusion queries issued               {}\n", s.queriesIssued);
    fmt::print("  query rounds (submissions waited for)  {}\n", s.queryRounds);
    fmt::print("  nodes culled by the mask, no query     {}\n", s.maskRejected);
    fmt::print("  camera culling ms                      {:.2f}\n", s.cameraMs);
    fmt::print("  receiver masks ms                      {:.2f}\n", s.maskMs);
    fmt::print("  caster culling ms                      {:.2f}\n", s.casterCullMs);
}

} // namespace penumbra::app
