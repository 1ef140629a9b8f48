// Batched scene draws (render::SceneGpu, config "draw_batching") against one draw per
// instance, on scenes of many small meshes: a 40 x 25 box grid (1,000 boxes, each its own
// mesh: indirect multi-draws) and the generated city (5 x 5 blocks, shared meshes:
// instancing), 1280 x 720, a sun shadowed by `hard` with a 2048² map, culling none (every
// instance drawn) and receiver-mask (instance masks split the batches; occlusion-query
// draws). Each iteration renders one frame; the iteration time is the frame's wall time
// (manual time). Counters, means over the iterations:
//   gbuffer_ms, shadow_ms   the G-buffer and shadow depth passes on the GPU
//   record_ms               the CPU time of recording those two passes (with culling, it
//                           includes the light view's caster culling, done at its first draw)
//   culling_ms              the visibility service's work (its own draws and queries)
//
//   cmake --build --preset ci --target penumbra_benchmarks
//   build/ci/tests/benchmarks/penumbra_benchmarks --benchmark_filter=DrawBatching --benchmark_min_time=2
//
// Figures (2 shared cores, load average 6-7, medians not taken: means of 5-13 frames):
//   box_grid/none      per-instance: frame 284 ms, gbuffer 85.2, shadow 46.9
//                      batched:      frame 233 ms, gbuffer 65.0, shadow 25.8
//   city/none          per-instance: frame 400 ms, gbuffer 166.2, shadow 97.0
//                      batched:      frame 349 ms, gbuffer 145.7, shadow 78.6
#include "BenchContext.h"

#include "penumbra/config/Config.h"
#include "penumbra/frame/FrameRenderer.h"
#include "penumbra/scene/Generators.h"

#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include <algorithm>
#include <string>

using namespace penumbra;

namespace {

enum class SceneKind { BoxGrid, City };

const scene::Scene& sceneOf(SceneKind kind)
{
    static const scene::Scene boxes = [] {
        scene::BoxGridParams p;
        p.columns = 40;
        p.rows = 25;
        p.spacing = 2.0f;
        p.boxSize = 0.9f;
        p.planeSize = 120.0f;
        return scene::generateBoxGrid(p);
    }();
    static const scene::Scene city = [] {
        scene::CityParams p;
        p.blocks = 5;
        p.seed = 3;
        return scene::generateCity(p);
    }();
    return kind == SceneKind::BoxGrid ? boxes : city;
}

config::RenderConfig frameConfig(SceneKind kind, config::CullingMode culling, bool batched)
{
    config::RenderConfig cfg;
    cfg.culling = culling;
    cfg.batchDraws = batched;
    cfg.keepUnchanged = false;  // every pass every frame: a still frame would keep them and time 0 ms
    const scene::Aabb bounds = sceneOf(kind).bounds();
    const glm::vec3 c = bounds.center(), e = bounds.max - bounds.min;
    cfg.camera.position = c + glm::vec3(-0.45f * e.x, 0.25f * std::max(e.x, e.z), -0.45f * e.z);
    cfg.camera.target = c;
    cfg.camera.fovYDeg = 60.0f;
    cfg.camera.nearWorld = 0.1f;
    cfg.lights.push_back(bench::hardSun({0.6f, -0.7f, 0.35f}));
    return cfg;
}

void BM_DrawBatching(benchmark::State& state, SceneKind kind, config::CullingMode culling, bool batched)
{
    const scene::Scene& scene = sceneOf(kind);
    frame::FrameRenderer renderer(bench::context(), scene, frameConfig(kind, culling, batched), bench::registry());
    renderer.renderFrame();  // lavapipe compiles pipelines at first use
    double gbuffer = 0.0, shadow = 0.0, record = 0.0, culled = 0.0;
    for (auto _ : state) {
        const frame::FrameTimings t = renderer.renderFrame();
        for (const frame::PassTiming& p : t.passes) {
            const bool isGBuffer = p.name == "gbuffer", isShadow = p.name == "light0.hard.shadow_map";
            if (isGBuffer) gbuffer += p.gpuMs;
            if (isShadow) shadow += p.gpuMs;
            if (isGBuffer || isShadow) record += p.cpuMs;
        }
        culled += t.culling.cameraMs + t.culling.maskMs + t.culling.casterCullMs;
        state.SetIterationTime(t.frameCpuMs / 1000.0);
    }
    const double n = double(std::max<int64_t>(state.iterations(), 1));
    state.counters["gbuffer_ms"] = gbuffer / n;
    state.counters["shadow_ms"] = shadow / n;
    state.counters["record_ms"] = record / n;
    state.counters["culling_ms"] = culled / n;
}

[[maybe_unused]] const bool batchingRegistered = [] {
    for (const SceneKind kind : {SceneKind::BoxGrid, SceneKind::City}) {
        for (const config::CullingMode culling : {config::CullingMode::None, config::CullingMode::ReceiverMask}) {
            for (const bool batched : {false, true}) {
                const std::string name =
                    fmt::format("DrawBatching/{}/{}/{}", kind == SceneKind::BoxGrid ? "box_grid" : "city",
                                config::cullingModeName(culling), batched ? "batched" : "per_instance");
                benchmark::RegisterBenchmark(name.c_str(), BM_DrawBatching, kind, culling, batched)
                    ->UseManualTime()
                    ->Unit(benchmark::kMillisecond);
            }
        }
    }
    return true;
}();

} // namespace
