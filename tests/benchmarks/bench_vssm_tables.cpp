// VSSM's tables against the floor (issue 19, "Measure"): the plugin's summed-area table
// (light0.vssm.sat) and min-max hierarchy (light0.vssm.hsm) as one frame builds them,
// side by side in each iteration with a plain prefix sum of the moments (t, t^2) over a
// float map of the same size (tests/benchmarks/shaders/prefix_sum.comp, the same
// row-then-column schedule):
// - floor_rg32f: RG32F sums, the plain table (which loses the variance at 1024^2 and
//   above: plugins/vssm/sat.glsl);
// - floor_fixed64: the plugin's own 64-bit fixed-point entries (sat.glsl), without the
//   map's depth linearisation; what lies between it and `sat` is that linearisation.
// Scenes: config/default.json under a directional light (one face of 1024² and 2048²) and
// under a sphere light (a cube atlas of six 1024² faces, 3072 x 2048). VSSM runs with
// subdivision `none` (the tables do not depend on it; the visibility pass is not timed).
// The iteration time is sat + hsm (manual time); counters give each pass's mean GPU ms,
// the floors' and the ratios sat_x_floor (sat over floor_rg32f) and tables_x_floor
// ((sat + hsm) over floor_rg32f). One warm-up frame first (lavapipe compiles pipelines
// at first use).
//
//   cmake --build --preset release --target penumbra_benchmarks
//   build/release/tests/benchmarks/penumbra_benchmarks --benchmark_filter='VssmTables'
//
// Figures: docs/vssm-bench.md, "The tables against a plain prefix sum".
#include "BenchContext.h"
#include "TestPaths.h"  // support/: the build tree's paths

#include "penumbra/config/Config.h"
#include "penumbra/core/Error.h"
#include "penumbra/frame/FrameRenderer.h"
#include "penumbra/gpu/Barrier.h"
#include "penumbra/gpu/Context.h"
#include "penumbra/gpu/GpuTimer.h"
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/gpu/Resources.h"
#include "penumbra/gpu/ShaderCompiler.h"

#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include <cmath>
#include <cstddef>
#include <filesystem>
#include <map>
#include <span>
#include <string>
#include <vector>

using namespace penumbra;

namespace {

using bench::context;
using bench::registry;

struct Case {
    const char* name;
    scene::LightType type;
    int resolution;
};

const Case kCases[] = {
    {"directional_1024", scene::LightType::Directional, 1024},
    {"directional_2048", scene::LightType::Directional, 2048},
    {"sphere_cube_1024", scene::LightType::Point, 1024},
};

config::LightConfig vssmLight(const Case& c)
{
    config::LightConfig light;
    light.name = "light";
    light.light.type = c.type;
    light.light.intensity = c.type == scene::LightType::Directional ? 3.0f : 900.0f;
    if (c.type == scene::LightType::Directional) {
        light.light.direction = glm::normalize(glm::vec3(0.4f, -1.0f, 0.3f));
        light.light.angularDiameterDeg = 2.0f;
    } else {
        light.light.position = glm::vec3(-3.0f, 6.0f, 2.0f);
        light.light.radiusWorld = 0.3f;
    }
    light.shadow.technique = "vssm";
    light.shadow.required = true;
    light.shadow.setParam("resolution", c.resolution, "benchmark");
    light.shadow.setParam("subdivision", "none", "benchmark");
    return light;
}

// The plain prefix sums: a float map of the table's size (depths of a smooth ramp with
// ripples, so that no two rows sum alike) and both entry formats.
class PrefixSumFloor {
public:
    PrefixSumFloor(gpu::Context& context, uint32_t width, uint32_t height)
        : context_(context), width_(width), height_(height), timer_(context, 2),
          compiler_({penumbra::test::sourceDir() / "tests/benchmarks/shaders", gpu::engineShaderDir(),
                     penumbra::test::sourceDir() / "plugins/vssm"}),
          sampler_(gpu::createSampler(context, VK_FILTER_NEAREST, VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE))
    {
        std::vector<float> depths(size_t(width) * height);
        for (uint32_t y = 0; y < height; ++y)
            for (uint32_t x = 0; x < width; ++x)
                depths[size_t(y) * width + x] =
                    0.5f + 0.3f * float(x + y) / float(width + height) + 0.05f * std::sin(0.01f * float(x * y % 997));
        map_ = gpu::uploadImage(context, width, height, VK_FORMAT_R32_SFLOAT, std::as_bytes(std::span(depths)),
                                "floor.depth");
        plain_ = gpu::Image(context, {width, height, VK_FORMAT_R32G32_SFLOAT, VK_IMAGE_USAGE_STORAGE_BIT, "floor.rg32f"});
        fixed_ = gpu::Image(context,
                            {width, height, VK_FORMAT_R32G32B32A32_UINT, VK_IMAGE_USAGE_STORAGE_BIT, "floor.fixed64"});
        plainPipeline_ = gpu::Pipeline(context, compiler_, gpu::ComputePipelineDesc{"floor_rg32f", "prefix_sum.comp", {}, 12});
        fixedPipeline_ = gpu::Pipeline(context, compiler_,
                                       gpu::ComputePipelineDesc{"floor_fixed64", "prefix_sum.comp", {{"FIXED_POINT", "1"}}, 12});
        context.submitAndWait([&](VkCommandBuffer cmd) {
            gpu::transition(cmd, plain_, gpu::access::kUndefined, gpu::access::kComputeWrite);
            gpu::transition(cmd, fixed_, gpu::access::kUndefined, gpu::access::kComputeWrite);
        });
    }

    // Both floors once; their GPU ms by name.
    std::vector<gpu::ScopeTime> run()
    {
        context_.submitAndWait([&](VkCommandBuffer cmd) {
            timer_.beginFrame(cmd);
            scan(cmd, plainPipeline_, plain_);
            scan(cmd, fixedPipeline_, fixed_);
        });
        return timer_.collect();
    }

private:
    struct Push {
        int32_t width, height, vertical;
    };

    void scan(VkCommandBuffer cmd, const gpu::Pipeline& pipeline, const gpu::Image& table)
    {
        // The last frame's column scan wrote the table: the row scan writes after it.
        gpu::memoryBarrier(cmd, gpu::access::kComputeStorageReadWrite, gpu::access::kComputeStorageReadWrite);
        const uint32_t scope = timer_.beginScope(cmd, pipeline.name());
        pipeline.bind(cmd);
        gpu::DescriptorPush()
            .sampledImage("depthMap", map_, sampler_)
            .storageImage(pipeline.name() == "floor_rg32f" ? "table" : "satImage", table)
            .push(context_, cmd, pipeline);
        Push push{int32_t(width_), int32_t(height_), 0};
        pipeline.pushConstants(cmd, &push, sizeof(push));
        pipeline.dispatchOver(cmd, height_);  // one invocation per row
        gpu::memoryBarrier(cmd, gpu::access::kComputeStorageWrite, gpu::access::kComputeStorageReadWrite);
        push.vertical = 1;
        pipeline.pushConstants(cmd, &push, sizeof(push));
        pipeline.dispatchOver(cmd, width_);  // one per column
        timer_.endScope(cmd, scope);
    }

    gpu::Context& context_;
    uint32_t width_, height_;
    gpu::GpuTimer timer_;
    gpu::ShaderCompiler compiler_;
    gpu::Sampler sampler_;
    gpu::Image map_, plain_, fixed_;
    gpu::Pipeline plainPipeline_, fixedPipeline_;
};

const graph::CompiledResource& resource(const graph::CompiledGraph& graph, const std::string& name)
{
    for (const graph::CompiledResource& r : graph.resources)
        if (r.name == name) return r;
    throw Error(fmt::format("bench_vssm_tables: the frame's graph has no resource '{}'", name));
}

void BM_VssmTables(benchmark::State& state, const Case& c)
{
    config::RenderConfig cfg = config::loadConfig(penumbra::test::sourceDir() / "config/default.json");
    cfg.width = 640;
    cfg.height = 360;
    cfg.keepUnchanged = false;  // every pass every frame: a still frame would keep them and time 0 ms
    cfg.lights = {vssmLight(c)};
    const scene::Scene scene = config::buildScene(cfg.scene);
    frame::FrameRenderer renderer(context(), scene, cfg, registry());
    renderer.renderFrame();
    const std::string prefix = renderer.shadowPassPrefix(0);
    const graph::CompiledResource& sat = resource(renderer.compiledGraph(), prefix + "sat");
    PrefixSumFloor floor(context(), sat.width, sat.height);
    floor.run();

    std::map<std::string, double> sums;
    for (auto _ : state) {
        double tablesMs = 0.0;
        for (const graph::PassTiming& pass : renderer.renderFrame().passes) {
            if (pass.name.rfind(prefix, 0) != 0) continue;
            const std::string name = pass.name.substr(prefix.size());
            sums[name] += pass.gpuMs;
            if (name == "sat" || name == "hsm") tablesMs += pass.gpuMs;
        }
        for (const gpu::ScopeTime& scope : floor.run()) sums[scope.name] += scope.gpuMs;
        state.SetIterationTime(tablesMs * 1e-3);
    }
    const double n = double(state.iterations());
    for (const auto& [name, sum] : sums) state.counters[name + "_ms"] = sum / n;
    const double floorMs = sums["floor_rg32f"];
    state.counters["sat_x_floor"] = floorMs > 0.0 ? sums["sat"] / floorMs : 0.0;
    state.counters["tables_x_floor"] = floorMs > 0.0 ? (sums["sat"] + sums["hsm"]) / floorMs : 0.0;
    state.counters["atlas_texels"] = double(sat.width) * double(sat.height);
}

const bool kRegistered = [] {
    for (const Case& c : kCases) {
        benchmark::RegisterBenchmark(fmt::format("BM_VssmTables/{}", c.name).c_str(), BM_VssmTables, c)
            ->UseManualTime()
            ->Unit(benchmark::kMillisecond)
            ->Iterations(5);
    }
    return true;
}();

} // namespace
