// The metrics on one 1280x720 pair (the default output size), as `penumbra compare` and
// `penumbra bench` run them per light: a soft-shadowed visibility image against a noisy
// copy, with a mask of 75 % geometry (the top quarter is sky), and the colour images.
//
//   cmake --build --preset release --target penumbra_benchmarks
//   build/release/tests/benchmarks/penumbra_benchmarks --benchmark_filter='Metrics' --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
//
// Figures: see README.md, "Comparing against the reference".
#include "penumbra/metrics/DifferenceImage.h"
#include "penumbra/metrics/ImageComparison.h"
#include "penumbra/metrics/Ssim.h"

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <random>

using namespace penumbra::metrics;

namespace {

constexpr uint32_t kWidth = 1280, kHeight = 720;

struct Pair {
    std::vector<float> reference, test;
    std::vector<uint8_t> referenceColor, testColor;
    PixelMask mask;
};

// Reference: soft-edged discs (umbra, penumbra and lit in proportions like a shadowed
// ground); test: the same plus noise of σ 0.05, clamped to [0, 1].
const Pair& pair()
{
    static const Pair p = [] {
        Pair p;
        const size_t n = size_t(kWidth) * kHeight;
        p.reference.resize(n);
        p.test.resize(n);
        p.referenceColor.resize(4 * n);
        p.testColor.resize(4 * n);
        p.mask = {kWidth, kHeight, std::vector<uint8_t>(n)};
        std::mt19937 rng(1);
        std::normal_distribution<float> noise(0.0f, 0.05f);
        for (uint32_t y = 0; y < kHeight; ++y)
            for (uint32_t x = 0; x < kWidth; ++x) {
                const size_t i = size_t(y) * kWidth + x;
                const float d = std::hypot(float(x % 256) - 128.0f, float(y % 256) - 128.0f);
                p.reference[i] = std::clamp((d - 60.0f) / 30.0f, 0.0f, 1.0f);
                p.test[i] = std::clamp(p.reference[i] + noise(rng), 0.0f, 1.0f);
                p.mask.covered[i] = y >= kHeight / 4;
                for (size_t c = 0; c < 3; ++c) {
                    p.referenceColor[4 * i + c] = uint8_t(std::lround(200.0f * p.reference[i]));
                    p.testColor[4 * i + c] = uint8_t(std::lround(200.0f * p.test[i]));
                }
                p.referenceColor[4 * i + 3] = p.testColor[4 * i + 3] = 255;
            }
        return p;
    }();
    return p;
}

FloatImageView view(const std::vector<float>& pixels) { return {kWidth, kHeight, pixels}; }

void MetricsCompareVisibility(benchmark::State& state)
{
    const Pair& p = pair();
    for (auto _ : state) benchmark::DoNotOptimize(compareVisibility(view(p.test), view(p.reference), &p.mask));
    state.SetItemsProcessed(int64_t(state.iterations()) * kWidth * kHeight);
}

void MetricsSsim(benchmark::State& state)
{
    const Pair& p = pair();
    for (auto _ : state) benchmark::DoNotOptimize(meanSsim(view(p.test), view(p.reference), &p.mask));
    state.SetItemsProcessed(int64_t(state.iterations()) * kWidth * kHeight);
}

void MetricsCompareColor(benchmark::State& state)
{
    const Pair& p = pair();
    for (auto _ : state) {
        benchmark::DoNotOptimize(
            compareColor({kWidth, kHeight, p.testColor}, {kWidth, kHeight, p.referenceColor}, &p.mask));
    }
    state.SetItemsProcessed(int64_t(state.iterations()) * kWidth * kHeight);
}

void MetricsDifferenceImage(benchmark::State& state)
{
    const Pair& p = pair();
    for (auto _ : state) benchmark::DoNotOptimize(differenceImage(view(p.test), view(p.reference), &p.mask));
    state.SetItemsProcessed(int64_t(state.iterations()) * kWidth * kHeight);
}

} // namespace

BENCHMARK(MetricsCompareVisibility)->Unit(benchmark::kMillisecond);
BENCHMARK(MetricsSsim)->Unit(benchmark::kMillisecond);
BENCHMARK(MetricsCompareColor)->Unit(benchmark::kMillisecond);
BENCHMARK(MetricsDifferenceImage)->Unit(benchmark::kMillisecond);
