// Modelling only what the frame requires, side by side in one run (docs/performance.md,
// "Images nobody reads" and "Only the pixels a light reaches"): each iteration draws the
// config's frame four times, every pass run (keep_unchanged false):
//   image         visibility images written and read by shading, every light shaded
//                 over the whole screen (the engine before both);
//   in_shading    shading evaluates hard / pcss / vsm visibility itself (no image);
//   regions       that, and each light shaded only over its rectangle of the screen;
//   image_regions visibility images written (as compare, bench and --visibility-exr
//                 keep them), each light's visibility pass and shading only over its
//                 rectangle.
// The iteration time is the regions frame's sum of GPU pass times (manual time); counters
// give each frame's sum, shading pass and visibility passes (mean GPU ms) and the ratios
// to `image`.
//
//   build/ci/tests/benchmarks/penumbra_benchmarks --benchmark_filter='ModelOnlyWhatIsRequired'
#include "BenchContext.h"
#include "TestPaths.h"  // support/: the build tree's paths

#include "penumbra/config/Config.h"
#include "penumbra/frame/FrameRenderer.h"

#include <benchmark/benchmark.h>

#include <array>
#include <string>

using namespace penumbra;

namespace {

using bench::context;
using bench::registry;

void BM_ModelOnlyWhatIsRequired(benchmark::State& state, const char* configName)
{
    config::RenderConfig cfg = config::loadConfig(penumbra::test::sourceDir() / "config" / configName);
    cfg.keepUnchanged = false;
    const scene::Scene scene = config::buildScene(cfg.scene);
    frame::FrameRenderer image(context(), scene, cfg, registry());
    frame::FrameRenderer inShading(context(), scene, cfg, registry());
    frame::FrameRenderer regions(context(), scene, cfg, registry());
    frame::FrameRenderer imageRegions(context(), scene, cfg, registry());
    image.setLightRegions(false);
    inShading.setLightRegions(false);
    inShading.setVisibilityReadBack(false);
    regions.setVisibilityReadBack(false);
    const std::array<frame::FrameRenderer*, 4> renderers{&image, &inShading, &regions, &imageRegions};
    const std::array<const char*, 4> names{"image", "in_shading", "regions", "image_regions"};
    for (frame::FrameRenderer* r : renderers) r->renderFrame();  // lavapipe compiles pipelines at first use

    std::array<double, 4> frameSum{}, shadingSum{}, visibilitySum{};
    const std::string visibilitySuffix = ".visibility";
    for (auto _ : state) {
        double timed = 0.0;
        for (size_t k = 0; k < renderers.size(); ++k) {
            double frameMs = 0.0;
            for (const graph::PassTiming& pass : renderers[k]->renderFrame().passes) {
                frameMs += pass.gpuMs;
                if (pass.name == "shading") shadingSum[k] += pass.gpuMs;
                if (pass.name.ends_with(visibilitySuffix)) visibilitySum[k] += pass.gpuMs;
            }
            frameSum[k] += frameMs;
            if (renderers[k] == &regions) timed = frameMs;
        }
        state.SetIterationTime(timed * 1e-3);
    }
    const double n = double(state.iterations());
    for (size_t k = 0; k < renderers.size(); ++k) {
        state.counters[std::string(names[k]) + "_frame_ms"] = frameSum[k] / n;
        state.counters[std::string(names[k]) + "_shading_ms"] = shadingSum[k] / n;
        state.counters[std::string(names[k]) + "_visibility_ms"] = visibilitySum[k] / n;
        if (k > 0) state.counters[std::string("x_image_") + names[k]] = frameSum[0] > 0.0 ? frameSum[k] / frameSum[0] : 0.0;
    }
}

BENCHMARK_CAPTURE(BM_ModelOnlyWhatIsRequired, default_scene, "default.json")
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond)
    ->Iterations(7);
BENCHMARK_CAPTURE(BM_ModelOnlyWhatIsRequired, box_field, "box-field.json")
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond)
    ->Iterations(7);
BENCHMARK_CAPTURE(BM_ModelOnlyWhatIsRequired, city_walk, "bench/city-walk.json")
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond)
    ->Iterations(5);

} // namespace
