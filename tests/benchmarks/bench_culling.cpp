// Caster culling (engine/src/visibility/) on the generated city: 13 x 13 blocks (over a
// million triangles, over 10,000 instances), a low sun shadowed by `hard` with a 2048²
// map, seen from the street and from a bird's-eye view, in the four culling modes side by
// side. Each iteration renders one frame; the iteration time is the frame's wall time
// (manual time). Counters, means over the iterations:
//   shadow_ms     the shadow depth pass on the GPU plus the culling work done for it
//                 (receiver masks and caster queries, wall clock)
//   depth_ms      the shadow depth pass alone (GPU)
//   mask_ms, cull_ms  the receiver masks, and the caster culling (wall clock)
//   camera_ms     the camera culling (step 1) before the G-buffer
//   triangles     triangles drawn into the shadow map
//   oracle        triangles of the casters that really shadow a visible pixel: every
//                 instance a shadow ray from a visible pixel towards the sun hits
//                 (tests/support/CasterOracle.h, once per view)
//   casters, queries, nodes: instance draws, occlusion queries, BVH nodes visited
//
//   cmake --build --preset release --target penumbra_benchmarks
//   build/release/tests/benchmarks/penumbra_benchmarks --benchmark_filter=Culling --benchmark_min_time=1x
//
// Figures: docs/culling.md.
#include "BenchContext.h"
#include "CasterOracle.h"

#include "penumbra/config/Config.h"
#include "penumbra/frame/FrameRenderer.h"
#include "penumbra/gpu/Context.h"
#include "penumbra/plugin/PluginRegistry.h"
#include "penumbra/scene/Generators.h"

#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <vector>

using namespace penumbra;

namespace {

constexpr uint32_t kCullingWidth = 640, kCullingHeight = 360;

using bench::context;
using bench::registry;

const scene::Scene& city()
{
    static const scene::Scene instance = [] {
        scene::CityParams p;
        p.blocks = 13;
        p.seed = 7;
        return scene::generateCity(p);
    }();
    return instance;
}

enum class View { Street, BirdsEye };

config::RenderConfig cityConfig(View view, config::CullingMode mode)
{
    config::RenderConfig cfg;
    cfg.width = kCullingWidth;
    cfg.height = kCullingHeight;
    cfg.culling = mode;
    cfg.keepUnchanged = false;  // every pass every frame: a still frame would keep them and time 0 ms
    const scene::Aabb bounds = city().bounds();
    const glm::vec3 c = bounds.center();
    if (view == View::Street) {
        // On the street between the middle block and its neighbour (blocks are 60 m with
        // 16 m streets: a street runs at 38 m from the centre), looking down it.
        cfg.camera.position = {c.x + 40.0f, 1.7f, c.z - 300.0f};
        cfg.camera.target = {c.x + 36.0f, 12.0f, c.z + 200.0f};
    } else {
        cfg.camera.position = {c.x - 300.0f, 500.0f, c.z - 300.0f};
        cfg.camera.target = c;
    }
    cfg.camera.fovYDeg = 60.0f;
    cfg.camera.nearWorld = 0.1f;
    cfg.lights.push_back(bench::hardSun({0.6f, -0.35f, 0.35f}));  // about 25° above the horizon
    return cfg;
}

// Triangles of the instances that some visible pixel's shadow ray hits.
uint64_t oracleTriangles(View view)
{
    static std::map<View, uint64_t> cache;
    if (auto it = cache.find(view); it != cache.end()) return it->second;
    const scene::Scene& scene = city();
    const config::RenderConfig cfg = cityConfig(view, config::CullingMode::None);
    frame::FrameRenderer renderer(context(), scene, cfg, registry());
    renderer.renderFrame();
    const uint64_t triangles = test::casterOracle(scene, renderer.readPositions(), renderer.readNormals(),
                                                  -glm::normalize(glm::dvec3(cfg.lights[0].light.direction)))
                                   .triangles;
    cache[view] = triangles;
    return triangles;
}

void BM_Culling(benchmark::State& state, View view, config::CullingMode mode)
{
    const scene::Scene& scene = city();
    const config::RenderConfig cfg = cityConfig(view, mode);
    const uint64_t oracle = oracleTriangles(view);
    frame::FrameRenderer renderer(context(), scene, cfg, registry());
    renderer.renderFrame();  // lavapipe compiles pipelines at first use
    const std::string depthPass = "light0.hard.shadow_map";
    double depthMs = 0.0, shadowMs = 0.0, cameraMs = 0.0, maskMs = 0.0, cullMs = 0.0;
    visibility::CullingStats last;
    for (auto _ : state) {
        const frame::FrameTimings t = renderer.renderFrame();
        double depth = 0.0;
        for (const frame::PassTiming& p : t.passes)
            if (p.name == depthPass) depth += p.gpuMs;
        depthMs += depth;
        shadowMs += depth + t.culling.maskMs + t.culling.casterCullMs;
        cameraMs += t.culling.cameraMs;
        maskMs += t.culling.maskMs;
        cullMs += t.culling.casterCullMs;
        last = t.culling;
        state.SetIterationTime(t.frameCpuMs / 1000.0);
    }
    const double n = double(std::max<int64_t>(state.iterations(), 1));
    state.counters["shadow_ms"] = shadowMs / n;
    state.counters["depth_ms"] = depthMs / n;
    state.counters["camera_ms"] = cameraMs / n;
    state.counters["mask_ms"] = maskMs / n;
    state.counters["cull_ms"] = cullMs / n;
    state.counters["triangles"] = double(last.trianglesDrawn);
    state.counters["oracle"] = double(oracle);
    state.counters["casters"] = double(last.castersDrawn);
    state.counters["queries"] = double(last.queriesIssued);
    state.counters["nodes"] = double(last.nodesVisited);
    state.counters["receivers"] = double(last.receivers);
}

[[maybe_unused]] const bool cullingRegistered = [] {
    for (const View view : {View::Street, View::BirdsEye}) {
        for (const config::CullingMode mode : {config::CullingMode::None, config::CullingMode::Frustum,
                                               config::CullingMode::LightOcclusion, config::CullingMode::ReceiverMask}) {
            const std::string name = fmt::format("Culling/{}/{}", view == View::Street ? "street" : "birds_eye",
                                                 config::cullingModeName(mode));
            benchmark::RegisterBenchmark(name.c_str(), BM_Culling, view, mode)->UseManualTime()->Unit(benchmark::kMillisecond);
        }
    }
    return true;
}();

} // namespace
