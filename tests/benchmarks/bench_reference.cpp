// Shadow rays per second of the reference plugin's Embree tracer (plugins/reference
// SceneTracer, one thread): rays from points spread over the ground of a scene to
// stratified points of a rectangular light above it, as the plugin traces them.
// Arg: the city's blocks per side (2: 25k triangles, 8: 400k, 13: 1.06M); the setup
// (BVH build) is not timed.
//
//   cmake --build --preset release --target penumbra_benchmarks
//   build/release/tests/benchmarks/penumbra_benchmarks --benchmark_filter='ShadowRays' --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
//
// Figures (medians of 5, 2 shared cores, release), items_per_second = rays/s on one
// thread: see plugins/reference/README.md ("Cost").
#include "reference/LightSampling.h"
#include "reference/SceneTracer.h"

#include "penumbra/scene/Generators.h"

#include <benchmark/benchmark.h>

#include <random>

using namespace penumbra;

namespace {

void BM_ShadowRays(benchmark::State& state)
{
    scene::CityParams params;
    params.blocks = uint32_t(state.range(0));
    const scene::Scene city = scene::generateCity(params);
    const reference::SceneTracer tracer(city);
    const scene::Aabb bounds = city.bounds();

    scene::Light light;
    light.type = scene::LightType::Rect;
    light.position = bounds.center() + glm::vec3(0.0f, bounds.extent().y + 0.25f * bounds.extent().x, 0.0f);
    light.direction = {0.0f, -1.0f, 0.0f};
    light.sizeWorld = glm::vec2(0.05f * bounds.extent().x);
    const reference::LightSampler sampler(light);

    // Receivers just above the ground, spread over the city (some in the open, some
    // under buildings, trees and cars).
    constexpr uint32_t kReceivers = 4096, kSamples = 16;
    std::mt19937 rng(1);
    std::uniform_real_distribution<float> ux(bounds.min.x, bounds.max.x), uz(bounds.min.z, bounds.max.z);
    std::vector<glm::vec3> receivers(kReceivers);
    for (glm::vec3& p : receivers) p = {ux(rng), 1e-3f * bounds.extent().x, uz(rng)};

    const reference::DenormalsAreZero denormals;
    reference::RayScratch scratch;
    const float offset = 1e-5f * tracer.sceneRadius();
    // Used by a counter, so not optimised away (benchmark::DoNotOptimize on a double
    // corrupts it with GCC 12 and Debian's benchmark 1.7: it picks a general register).
    double lit = 0.0;
    for (auto _ : state) {
        for (uint32_t i = 0; i < kReceivers; ++i)
            for (uint32_t s = 0; s < kSamples; ++s) {
                const reference::ShadowRay ray =
                    sampler.sample(glm::dvec3(receivers[i]), reference::stratifiedSample(s, kSamples, i));
                lit += tracer.transmittance(receivers[i], glm::vec3(ray.direction), float(ray.length), offset, scratch);
            }
    }
    state.SetItemsProcessed(int64_t(state.iterations()) * kReceivers * kSamples);
    state.counters["triangles"] = double(city.triangleCount());
    state.counters["lit_percent"] = 100.0 * lit / double(state.iterations() * kReceivers * kSamples);
}
BENCHMARK(BM_ShadowRays)->Arg(2)->Arg(8)->Arg(13)->Unit(benchmark::kMillisecond);

} // namespace
