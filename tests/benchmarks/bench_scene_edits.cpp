// What an edit costs until its frame is drawn (the viewer's edit latency, without the
// window), against a camera move, side by side in one run:
//   Edit/kept   - a parameter of light 0 changed: a renderer over the scene's long-lived
//                 resources (frame::SceneResources) that keeps the other lights' techniques
//                 (what the viewer does), and its first frame;
//   Edit/fresh  - the same edit drawn by a renderer of its own: the scene uploaded again,
//                 its BVH and visibility service built again, every technique created
//                 again (what an edit cost before the resources outlived a configuration);
//   CameraMove  - the camera moved: FrameRenderer::update and one frame.
// On config/default.json (27 instances, one hard spot) and config/bench/edit-latency-city.json
// (102,410 triangles, a hard sun and an adaptive-sm spot: the sun's edit leaves the
// spot's quadtree as it grew). Wall time per iteration (the frame waits for the device).
//
//   cmake --build --preset ci --target penumbra_benchmarks
//   build/ci/tests/benchmarks/penumbra_benchmarks --benchmark_filter='SceneEdit' --benchmark_repetitions=3 --benchmark_report_aggregates_only=true
//
// Figures: docs/performance.md ("Edits over one scene").
#include "BenchContext.h"
#include "TestPaths.h"  // support/: the build tree's paths

#include "penumbra/config/Config.h"
#include "penumbra/config/Run.h"
#include "penumbra/frame/FrameRenderer.h"
#include "penumbra/frame/SceneResources.h"

#include <benchmark/benchmark.h>

#include <memory>
#include <string>

using namespace penumbra;

namespace {

enum class Path { Kept, Fresh, CameraMove };

// A parameter of light 0 (hard, in both configs) that changes its passes' constants only.
void editLight0(config::RenderConfig& config, int64_t iteration)
{
    config.lights[0].shadow.setParam("normal_offset", iteration % 2 == 1 ? 1.5 : 1.0, "bench");  // 1.0: the default
}

void sceneEdit(benchmark::State& state, const char* file, Path path)
{
    config::PreparedRun run = config::prepareRun(test::sourceDir() / file, {});
    config::RenderConfig config = run.config;
    auto resources = std::make_shared<frame::SceneResources>(bench::context(), run.scene,
                                                             frame::SceneResources::batchingOf(config));
    auto renderer = std::make_unique<frame::FrameRenderer>(resources, config, bench::registry());
    // Settled first: an adaptive shadow map refines its quadtree over the first frames.
    for (int i = 0; i < 3; ++i) renderer->renderFrame();
    int64_t iteration = 0;
    uint64_t kept = 0;
    for (auto _ : state) {
        ++iteration;
        if (path == Path::CameraMove) {
            config.camera.position.x += iteration % 2 == 0 ? 0.05f : -0.05f;
            renderer->update(config, run.scene, {});
            renderer->renderFrame();
            continue;
        }
        editLight0(config, iteration);
        if (path == Path::Kept) {
            auto next = std::make_unique<frame::FrameRenderer>(resources, config, bench::registry(), renderer.get());
            next->renderFrame();
            for (size_t l = 0; l < next->lightCount(); ++l) kept += next->techniqueKept(l);
            renderer = std::move(next);
        } else {
            renderer.reset();  // as the viewer did: one renderer's memory at a time
            renderer = std::make_unique<frame::FrameRenderer>(bench::context(), run.scene, config, bench::registry());
            renderer->renderFrame();
        }
    }
    state.counters["techniques_kept_per_edit"] = iteration > 0 ? double(kept) / double(iteration) : 0.0;
}

void registerSceneEdits()
{
    for (const auto& [name, file] : {std::pair{"default", "config/default.json"},
                                     std::pair{"city", "config/bench/edit-latency-city.json"}}) {
        for (const auto& [pathName, path] :
             {std::pair{"kept", Path::Kept}, std::pair{"fresh", Path::Fresh}, std::pair{"camera_move", Path::CameraMove}}) {
            benchmark::RegisterBenchmark((std::string("SceneEdit/") + name + "/" + pathName).c_str(), sceneEdit, file, path)
                ->Unit(benchmark::kMillisecond)
                ->Iterations(10);
        }
    }
}

const int kSceneEditsRegistered = (registerSceneEdits(), 0);

} // namespace
