// Render graph compile time at 100 and 1,000 passes (random graphs from
// tests/support/RandomGraph: 1-2 fresh resources written per pass, up to 3 reads).
// Figures (medians of 5, 2 shared cores, release):
//   cmake --build --preset release --target penumbra_benchmarks
//   build/release/tests/benchmarks/penumbra_benchmarks --benchmark_filter=RenderGraph --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
//   compile, 100 passes: 83 us; 1,000 passes: 1.04 ms; cached (unchanged declaration): 7 ns.
#include "RandomGraph.h"

#include <benchmark/benchmark.h>

using namespace penumbra;

namespace {

// A full compile: order, cull, lifetimes, aliasing, barriers. The graph is declared
// afresh outside the timed region so that no cached result is reused.
void BM_RenderGraphCompile(benchmark::State& state)
{
    const auto passes = uint32_t(state.range(0));
    for (auto _ : state) {
        state.PauseTiming();
        graphtest::RandomGraph record;
        graphtest::buildRandomGraph(record, passes, 7);
        state.ResumeTiming();
        benchmark::DoNotOptimize(record.graph.compile());
    }
}
BENCHMARK(BM_RenderGraphCompile)->Arg(100)->Arg(1000)->Unit(benchmark::kMicrosecond);

// An unchanged declaration: the per-frame cost when nothing changed.
void BM_RenderGraphCompileCached(benchmark::State& state)
{
    graphtest::RandomGraph record;
    graphtest::buildRandomGraph(record, uint32_t(state.range(0)), 7);
    record.graph.compile();
    for (auto _ : state) benchmark::DoNotOptimize(record.graph.compile());
}
BENCHMARK(BM_RenderGraphCompileCached)->Arg(100)->Arg(1000);

} // namespace
