// InstanceBvh build, refit and queries at 10k and 100k instances. Figures:
//   cmake --build --preset release --target penumbra_benchmarks
//   build/release/tests/benchmarks/penumbra_benchmarks --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include "penumbra/render/Projection.h"
#include "penumbra/scene/Bvh.h"

#include <benchmark/benchmark.h>

#include <cmath>
#include <random>

using namespace penumbra;
using namespace penumbra::scene;

namespace {

// Instances at the density of 10k in a cube of edge 200 (a town block of props): edges
// log-uniform in [0.1, 10], one in a hundred a building-sized 20 to 40.
float sceneEdge(size_t count) { return 200.0f * std::cbrt(float(count) / 10000.0f); }

std::vector<Aabb> randomBoxes(size_t count, uint32_t seed)
{
    std::mt19937 rng(seed);
    const float half = 0.5f * sceneEdge(count);
    std::uniform_real_distribution<float> position(-half, half);
    std::uniform_real_distribution<float> logEdge(-1.0f, 1.0f);
    std::uniform_real_distribution<float> buildingEdge(20.0f, 40.0f);
    std::uniform_int_distribution<int> percent(0, 99);
    std::vector<Aabb> boxes(count);
    for (Aabb& box : boxes) {
        const glm::vec3 center{position(rng), position(rng), position(rng)};
        glm::vec3 edge{std::pow(10.0f, logEdge(rng)), std::pow(10.0f, logEdge(rng)), std::pow(10.0f, logEdge(rng))};
        if (percent(rng) == 0) edge = glm::vec3(buildingEdge(rng));
        box = Aabb{center - 0.5f * edge, center + 0.5f * edge};
    }
    return boxes;
}

// Every box moved by up to 1 (animation between two frames).
std::vector<Aabb> jittered(std::vector<Aabb> boxes, uint32_t seed)
{
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> shift(-1.0f, 1.0f);
    for (Aabb& box : boxes) {
        const glm::vec3 d{shift(rng), shift(rng), shift(rng)};
        box = Aabb{box.min + d, box.max + d};
    }
    return boxes;
}

// Cameras inside the scene looking in random directions, 60° vertical field of view.
std::vector<Frustum> randomFrusta(size_t count, size_t instances, uint32_t seed)
{
    std::mt19937 rng(seed);
    const float half = 0.5f * sceneEdge(instances);
    std::uniform_real_distribution<float> position(-half, half);
    std::vector<Frustum> frusta;
    for (size_t i = 0; i < count; ++i) {
        Camera camera;
        camera.position = {position(rng), position(rng), position(rng)};
        camera.target = {position(rng), position(rng), position(rng)};
        camera.fovYDeg = 60.0f;
        frusta.push_back(frustumFromViewProj(render::cameraViewProj(camera, 16.0f / 9.0f)));
    }
    return frusta;
}

// Picking rays from random points inside the scene in random directions.
std::vector<Ray> randomRays(size_t count, size_t instances, uint32_t seed)
{
    std::mt19937 rng(seed);
    const float half = 0.5f * sceneEdge(instances);
    std::uniform_real_distribution<float> position(-half, half);
    std::normal_distribution<float> gauss;
    std::vector<Ray> rays(count);
    for (Ray& ray : rays) {
        ray.origin = {position(rng), position(rng), position(rng)};
        ray.direction = glm::normalize(glm::vec3(gauss(rng), gauss(rng), gauss(rng)));
    }
    return rays;
}

void BvhBuild(benchmark::State& state)
{
    const std::vector<Aabb> boxes = randomBoxes(size_t(state.range(0)), 1);
    for (auto _ : state) {
        InstanceBvh bvh(boxes);
        benchmark::DoNotOptimize(bvh.nodeCount());
    }
    state.SetItemsProcessed(int64_t(state.iterations()) * state.range(0));
}

// Alternates between two sets of boxes so that each refit changes every node.
void BvhRefit(benchmark::State& state)
{
    const std::vector<Aabb> frames[2] = {randomBoxes(size_t(state.range(0)), 1), jittered(randomBoxes(size_t(state.range(0)), 1), 2)};
    InstanceBvh bvh(frames[0]);
    size_t frame = 0;
    for (auto _ : state) {
        bvh.refit(frames[++frame % 2]);
        benchmark::ClobberMemory();
    }
    // How much the jitter wears the tree: the refitted cost over the built one.
    bvh.refit(frames[1]);
    state.counters["sahGrowth"] = bvh.sahCost() / bvh.builtSahCost();
}

// One instance in a hundred moved, as Scene::updateTransforms reports them.
void BvhRefitChanged(benchmark::State& state)
{
    const auto count = size_t(state.range(0));
    const std::vector<Aabb> frames[2] = {randomBoxes(count, 1), jittered(randomBoxes(count, 1), 2)};
    std::vector<uint32_t> changed;
    for (uint32_t i = 0; i < count; i += 100) changed.push_back(i);
    InstanceBvh bvh(frames[0]);
    size_t frame = 0;
    for (auto _ : state) {
        bvh.refit(frames[++frame % 2], changed);
        benchmark::ClobberMemory();
    }
}

void BvhFrustum(benchmark::State& state)
{
    const auto count = size_t(state.range(0));
    const InstanceBvh bvh(randomBoxes(count, 1));
    const std::vector<Frustum> frusta = randomFrusta(64, count, 3);
    std::vector<uint32_t> visible;
    size_t next = 0;
    size_t visibleTotal = 0;
    for (auto _ : state) {
        bvh.cullFrustum(frusta[next++ % frusta.size()], visible);
        visibleTotal += visible.size();
    }
    state.counters["visible"] = double(visibleTotal) / double(state.iterations());
}

constexpr size_t kRaysPerIteration = 1024;

void BvhRayClosest(benchmark::State& state)
{
    const auto count = size_t(state.range(0));
    const InstanceBvh bvh(randomBoxes(count, 1));
    const std::vector<Ray> rays = randomRays(kRaysPerIteration, count, 4);
    for (auto _ : state) {
        for (const Ray& ray : rays) benchmark::DoNotOptimize(bvh.closestHit(ray));
    }
    state.SetItemsProcessed(int64_t(state.iterations() * rays.size()));
}

void BvhRayAllHits(benchmark::State& state)
{
    const auto count = size_t(state.range(0));
    const InstanceBvh bvh(randomBoxes(count, 1));
    const std::vector<Ray> rays = randomRays(kRaysPerIteration, count, 4);
    std::vector<RayHit> hits;
    for (auto _ : state) {
        for (const Ray& ray : rays) {
            bvh.findAllHits(ray, hits);
            benchmark::DoNotOptimize(hits.data());
        }
    }
    state.SetItemsProcessed(int64_t(state.iterations() * rays.size()));
}

// Every node, nearest first: the upper bound of a CHC++ traversal that culls nothing.
void BvhFrontToBack(benchmark::State& state)
{
    const auto count = size_t(state.range(0));
    const InstanceBvh bvh(randomBoxes(count, 1));
    const std::vector<Ray> viewpoints = randomRays(64, count, 5);
    size_t next = 0;
    for (auto _ : state) {
        uint32_t leaves = 0;
        bvh.traverseFrontToBack(viewpoints[next++ % viewpoints.size()].origin, [&](const BvhNodeVisit& visit) {
            leaves += visit.instances.empty() ? 0 : 1;
            return true;
        });
        benchmark::DoNotOptimize(leaves);
    }
}

} // namespace

BENCHMARK(BvhBuild)->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond);
BENCHMARK(BvhRefit)->Arg(10000)->Arg(100000)->Unit(benchmark::kMicrosecond);
BENCHMARK(BvhRefitChanged)->Arg(10000)->Arg(100000)->Unit(benchmark::kMicrosecond);
BENCHMARK(BvhFrustum)->Arg(10000)->Arg(100000)->Unit(benchmark::kMicrosecond);
BENCHMARK(BvhRayClosest)->Arg(10000)->Arg(100000)->Unit(benchmark::kMicrosecond);
BENCHMARK(BvhRayAllHits)->Arg(10000)->Arg(100000)->Unit(benchmark::kMicrosecond);
BENCHMARK(BvhFrontToBack)->Arg(10000)->Arg(100000)->Unit(benchmark::kMicrosecond);

BENCHMARK_MAIN();
