// Loading a config of many objects, as `penumbra validate` and every command start: the
// file read and parsed (config::loadDocument), then read as a config (parseConfig). Two
// shapes that a naive reader makes quadratic: N empty objects in one array (nlohmann's
// callback parser scans the array at each closing object) and an animation of N keys
// (each key an object, each recorded as an origin). The time per object should stay
// flat from 10k to 100k.
//
//   cmake --build --preset release --target penumbra_benchmarks
//   build/release/tests/benchmarks/penumbra_benchmarks --benchmark_filter='Config' --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
//
// Figures: README.md, the paragraph "Problems a run can meet" (2-core CI-class machine:
// 100,000 keys 174 ms, 10,000 keys 20.7 ms; 100,000 empty objects 30.8 ms, 10,000 2.5 ms).
#include "penumbra/config/Config.h"

#include <benchmark/benchmark.h>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>

namespace fs = std::filesystem;
using namespace penumbra;

namespace {

const char* kBase = R"({"camera": {"position": [0, 5, 10], "target": [0, 0, 0]},
    "lights": [{"type": "spot", "position": [0, 10, 0], "target": [0, 0, 0]}])";

// A config file of `text` in the temporary folder, removed with the object.
class ConfigFile {
public:
    explicit ConfigFile(const std::string& text)
        : path_(fs::temp_directory_path() / fmt::format("penumbra_bench_config_{}.json", ::getpid()))
    {
        std::ofstream(path_, std::ios::binary) << text;
    }
    ~ConfigFile() { fs::remove(path_); }
    const fs::path& path() const { return path_; }

private:
    fs::path path_;
};

// N empty objects in an array under a key of its own: loading only (parseConfig would
// refuse the unknown key).
void BM_ConfigLoadEmptyObjects(benchmark::State& state)
{
    std::string text = std::string(kBase) + R"(, "x": [)";
    for (int64_t i = 0; i < state.range(0); ++i) text += i ? ",{}" : "{}";
    const ConfigFile file(text + "]}");
    for (auto _ : state) benchmark::DoNotOptimize(config::loadDocument(file.path()));
    state.SetItemsProcessed(state.iterations() * state.range(0));
}
BENCHMARK(BM_ConfigLoadEmptyObjects)->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond);

// An animation track of N keys: loaded and read as a config.
void BM_ConfigAnimationKeys(benchmark::State& state)
{
    std::string text = std::string(kBase) + R"(, "animation": {"fps": 30, "tracks": [{"target": "/camera/fov_y_deg", "keys": [)";
    for (int64_t i = 0; i < state.range(0); ++i) text += fmt::format(R"({}{{"t": {}, "value": 45}})", i ? "," : "", i * 0.01);
    const ConfigFile file(text + "]}]}}");
    for (auto _ : state) benchmark::DoNotOptimize(config::parseConfig(config::loadDocument(file.path())));
    state.SetItemsProcessed(state.iterations() * state.range(0));
}
BENCHMARK(BM_ConfigAnimationKeys)->Arg(10000)->Arg(100000)->Unit(benchmark::kMillisecond);

} // namespace
