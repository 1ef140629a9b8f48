// GPU time of each shadow technique's passes: config/default.json (27 instances, 9,326
// triangles) at 1280 x 720, its spot light shadowed with a 2048² map by hard, pcss and
// the VSM family's variants and filters. Each iteration renders one frame through
// frame::FrameRenderer; the iteration time is the sum of the technique's passes' GPU
// times (timestamps, manual time), and a counter per pass gives its mean GPU ms. One
// warm-up frame first (lavapipe compiles pipelines at first use).
//
//   cmake --build --preset release --target penumbra_benchmarks
//   build/release/tests/benchmarks/penumbra_benchmarks --benchmark_filter='Shadow' --benchmark_repetitions=3 --benchmark_report_aggregates_only=true
//
// The same figures for any config: penumbra render CONFIG -o out.png --frames 30 --timings.
// Figures: see plugins/pcss/README.md and plugins/vsm/README.md.
#include "BenchContext.h"
#include "TestPaths.h"  // support/: the build tree's paths

#include "penumbra/config/Config.h"
#include "penumbra/frame/FrameRenderer.h"
#include "penumbra/gpu/Context.h"
#include "penumbra/plugin/PluginRegistry.h"

#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include <filesystem>
#include <map>
#include <string>
#include <utility>
#include <vector>

using namespace penumbra;

namespace {

struct Technique {
    const char* name;  // the benchmark's
    const char* plugin;
    std::vector<std::pair<const char*, nlohmann::json>> params;
};

const Technique kTechniques[] = {
    {"hard", "hard", {{"resolution", 2048}}},
    {"hard_pcf5", "hard", {{"resolution", 2048}, {"filter", "pcf"}, {"pcf_kernel", 5}}},
    {"pcss", "pcss", {{"resolution", 2048}, {"light_size", 1.0}}},
    {"pcss_64_64", "pcss", {{"resolution", 2048}, {"light_size", 1.0}, {"blocker_samples", 64}, {"filter_samples", 64}}},
    {"vsm_gaussian2", "vsm", {{"resolution", 2048}, {"variant", "vsm"}}},
    {"vsm_gaussian8", "vsm", {{"resolution", 2048}, {"variant", "vsm"}, {"blur_radius", 8}}},
    {"vsm_trilinear", "vsm", {{"resolution", 2048}, {"variant", "vsm"}, {"filter", "trilinear"}}},
    {"vsm_anisotropic", "vsm", {{"resolution", 2048}, {"variant", "vsm"}, {"filter", "anisotropic"}}},
    {"evsm_gaussian2", "vsm", {{"resolution", 2048}, {"variant", "evsm"}}},
    {"evsm_rgba16f", "vsm", {{"resolution", 2048}, {"variant", "evsm"}, {"moment_format", "rgba16f"}}},
    {"esm_gaussian2", "vsm", {{"resolution", 2048}, {"variant", "esm"}}},
};

using bench::context;
using bench::registry;

void BM_ShadowTechnique(benchmark::State& state, const Technique& technique)
{
    config::RenderConfig cfg = config::loadConfig(penumbra::test::sourceDir() / "config/default.json");
    cfg.width = 1280;
    cfg.height = 720;
    cfg.keepUnchanged = false;  // every pass every frame: a still frame would keep them and time 0 ms
    config::ShadowSettings& shadow = cfg.lights[0].shadow;
    shadow = {};
    shadow.technique = technique.plugin;
    shadow.required = true;
    for (const auto& [name, value] : technique.params) shadow.setParam(name, value, "benchmark");
    const scene::Scene scene = config::buildScene(cfg.scene);
    frame::FrameRenderer renderer(context(), scene, cfg, registry());
    renderer.renderFrame();

    const std::string prefix = fmt::format("light0.{}.", technique.plugin);
    std::map<std::string, double> sums;
    for (auto _ : state) {
        double seconds = 0.0;
        for (const graph::PassTiming& pass : renderer.renderFrame().passes) {
            if (pass.name.rfind(prefix, 0) != 0) continue;
            sums[pass.name.substr(prefix.size())] += pass.gpuMs;
            seconds += pass.gpuMs * 1e-3;
        }
        state.SetIterationTime(seconds);
    }
    for (const auto& [pass, sum] : sums) state.counters[pass + "_ms"] = sum / double(state.iterations());
}

const bool kRegistered = [] {
    for (const Technique& t : kTechniques) {
        benchmark::RegisterBenchmark(fmt::format("BM_ShadowTechnique/{}", t.name).c_str(), BM_ShadowTechnique, t)
            ->UseManualTime()
            ->Unit(benchmark::kMillisecond)
            ->Iterations(10);
    }
    return true;
}();

} // namespace
