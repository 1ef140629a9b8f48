// The frame against the rasterizer's floor (frame/FloorRenderer.h), side by side: the box
// field of the classic shadow benchmark (config/box-field.json: 1,000 boxes, 12k
// triangles in 1,001 meshes, 1280 x 720, one directional light with a 2048² hard shadow
// map) and its 972k-triangle variant (config/box-field-dense.json). Each iteration renders
// one frame through frame::FrameRenderer, then the floor; the iteration time is the
// frame's sum of GPU pass times (manual time). Counters: frame_ms, floor_ms (the shadowed
// floor frame: its shadow map plus its forward draw with the compare), x_floor (their
// ratio: issue 18's goal is <= 1.3), and each pass's mean GPU ms (frame passes by name,
// floor passes as floor.*). One warm-up frame of each first (lavapipe compiles pipelines
// at first use).
//
//   cmake --build --preset release --target penumbra_benchmarks
//   build/release/tests/benchmarks/penumbra_benchmarks --benchmark_filter='FrameAgainstFloor'
//
// The same figures for any config: penumbra render CONFIG -o out.png --frames 9 --warmup 2 --timings.
// Figures: docs/performance.md.
#include "BenchContext.h"
#include "TestPaths.h"  // support/: the build tree's paths

#include "penumbra/config/Config.h"
#include "penumbra/frame/FloorRenderer.h"
#include "penumbra/frame/FrameRenderer.h"

#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include <filesystem>
#include <map>
#include <string>

using namespace penumbra;

namespace {

using bench::context;
using bench::registry;

void BM_FrameAgainstFloor(benchmark::State& state, const char* configName)
{
    config::RenderConfig cfg = config::loadConfig(penumbra::test::sourceDir() / "config" / configName);
    cfg.keepUnchanged = false;  // every pass every frame: a still frame would keep them and time 0 ms
    const scene::Scene scene = config::buildScene(cfg.scene);
    frame::FrameRenderer renderer(context(), scene, cfg, registry());
    frame::FloorRenderer floor(context(), scene, cfg);
    renderer.renderFrame();
    floor.renderFrame();

    std::map<std::string, double> sums;
    double frameSum = 0.0, floorSum = 0.0;
    for (auto _ : state) {
        double frameMs = 0.0, floorMs = 0.0;
        for (const graph::PassTiming& pass : renderer.renderFrame().passes) {
            sums[pass.name] += pass.gpuMs;
            frameMs += pass.gpuMs;
        }
        for (const graph::PassTiming& pass : floor.renderFrame().passes) {
            sums[pass.name] += pass.gpuMs;
            if (pass.name.rfind(frame::kFloorShadowedPrefix, 0) == 0) floorMs += pass.gpuMs;
        }
        frameSum += frameMs;
        floorSum += floorMs;
        state.SetIterationTime(frameMs * 1e-3);
    }
    const double n = double(state.iterations());
    for (const auto& [pass, sum] : sums) state.counters[pass + "_ms"] = sum / n;
    state.counters["frame_ms"] = frameSum / n;
    state.counters["floor_ms"] = floorSum / n;
    state.counters["x_floor"] = floorSum > 0.0 ? frameSum / floorSum : 0.0;
}

BENCHMARK_CAPTURE(BM_FrameAgainstFloor, box_field, "box-field.json")
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond)
    ->Iterations(9);
BENCHMARK_CAPTURE(BM_FrameAgainstFloor, box_field_dense, "box-field-dense.json")
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond)
    ->Iterations(5);

} // namespace
