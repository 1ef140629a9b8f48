#include "GraphCommand.h"

#include "TimingSummary.h"

#include "penumbra/config/Run.h"
#include "penumbra/core/Error.h"
#include "penumbra/frame/FrameRenderer.h"
#include "penumbra/io/StagedFile.h"
#include "penumbra/plugin/PluginRegistry.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

#include <cstdio>
#include <memory>

namespace penumbra::app {
namespace {

struct GraphFlags {
    std::string config;
    std::string format = "text";  // "text" or "dot"
    std::string output;           // empty: stdout
    RunFlags run;
    DeviceFlags device;
};

std::string mebibytes(VkDeviceSize bytes) { return fmt::format("{:.2f} MiB", double(bytes) / (1024.0 * 1024.0)); }

// The visibility service culls in submissions of its own, outside the graph: the camera
// before the passes run, each light view when a pass first draws its casters (so inside
// that pass's CPU time). The graph shows no pass for them; this says so, with their
// figures for the frame.
std::string cullingSection(const visibility::CullingStats& stats, config::CullingMode mode)
{
    std::string text =
        fmt::format("outside the graph: culling {} (the visibility service's own submissions, waited for: the "
                    "camera's before the passes, each light view's in the pass that first draws its casters)\n",
                    config::cullingModeName(mode));
    for (const CullingFigure& figure : cullingFigures()) {
        const std::string_view key = figure.key;
        if (key != "camera_ms" && key != "mask_ms" && key != "caster_cull_ms" && key != "query_rounds") continue;
        if (figure.count)
            text += fmt::format("  {:<39}{}\n", figure.label, stats.*figure.count);
        else
            text += fmt::format("  {:<39}{:.2f}\n", figure.label, stats.*figure.ms);
    }
    return text;
}

// The lights whose V_l shading evaluates: no visibility pass, no image.
std::string visibilityInShadingText(const frame::FrameRenderer& renderer)
{
    std::vector<std::string> lights;
    for (size_t l = 0; l < renderer.lightCount(); ++l)
        if (renderer.visibilityInShading(l)) lights.push_back(fmt::format("light {} ({})", l, renderer.techniqueName(l)));
    if (lights.empty()) return {};
    return fmt::format("visibility evaluated in shading, no image (render --visibility-exr or --debug-image keeps "
                       "one): {}\n",
                       fmt::join(lights, ", "));
}

// Where shading added each light in the last frame (FrameRenderer::shadingRegions).
std::string shadingRegionsText(const frame::FrameRenderer& renderer)
{
    const auto& regions = renderer.shadingRegions();
    const double pixels = double(renderer.width()) * double(renderer.height());
    std::vector<std::string> lights;
    for (size_t l = 0; l < renderer.lightCount(); ++l) {
        double shaded = 0.0;
        for (const auto& r : regions)
            if ((r.shaded >> l) & 1u) shaded += double(r.rect.x1 - r.rect.x0) * double(r.rect.y1 - r.rect.y0);
        lights.push_back(fmt::format("light {} {:.1f}%", l, pixels > 0.0 ? 100.0 * shaded / pixels : 0.0));
    }
    return fmt::format("shading: {} rectangle(s); each light added over its screen bounds, share of the pixels: {}\n",
                       regions.size(), fmt::join(lights, ", "));
}

int runGraph(const GraphFlags& flags)
{
    config::RenderConfig loaded = loadConfigIgnoringSweep(flags.config, "graph");
    const config::RunOptions options = runOptions(flags.run);
    if (!flags.output.empty()) io::checkWritable(flags.output);
    const config::PreparedRun run = config::prepareRun(std::move(loaded), options);
    plugin::PluginRegistry plugins;
    checkPluginsBeforeDevice(run.config, options, plugins);

    gpu::Context context(contextOptions(flags.device));
    frame::FrameRenderer renderer(context, run.scene, run.config, plugins);
    for (const std::string& warning : renderer.warnings()) spdlog::warn("{}", warning);
    renderer.setVisibilityReadBack(false);  // the frame `render` draws
    const frame::FrameTimings timings = renderer.renderFrame();

    const graph::CompiledGraph& compiled = renderer.compiledGraph();
    std::string text;
    if (flags.format == "dot") {
        text = compiled.toDot();
    } else {
        text = compiled.toText();
        // The compiler's figures are estimates; these are the allocations the device made.
        const VkDeviceSize unaliased = renderer.executor().transientBytesWithoutAliasing();
        const VkDeviceSize allocated = renderer.executor().transientBytesAllocated();
        const double saved = unaliased > 0 ? 100.0 * double(unaliased - std::min(allocated, unaliased)) / double(unaliased) : 0.0;
        text += fmt::format("device memory for transient resources: {} allocated, {} without aliasing ({:.1f}% saved)\n",
                            mebibytes(allocated), mebibytes(unaliased), saved);
        text += cullingSection(timings.culling, run.config.culling);
        text += lightFatesText({timings}, run.config.lights);
        std::vector<std::string> techniques;
        for (size_t l = 0; l < renderer.lightCount(); ++l) techniques.push_back(renderer.techniqueName(l));
        text += techniqueFiguresText(timings.techniques, techniques);
        text += visibilityInShadingText(renderer);
        text += shadingRegionsText(renderer);
        // Every image a pass writes, culled passes' too: requesting one keeps its passes
        // (and the lights' visibility images).
        renderer.setVisibilityReadBack(true);
        text += fmt::format("debug images (penumbra render --debug-image NAME): {}\n",
                            fmt::join(renderer.imageNames(), ", "));
    }
    if (flags.output.empty()) {
        std::fputs(text.c_str(), stdout);
    } else {
        io::StagedFile file(flags.output);
        std::ofstream out = file.openTemp();
        out << text;
        out.close();
        if (!out) throw Error(fmt::format("{}: could not write the graph", flags.output));
        file.commit();
        spdlog::info("wrote {}", flags.output);
    }
    return 0;
}

} // namespace

Command addGraphCommand(CLI::App& app)
{
    auto flags = std::make_shared<GraphFlags>();
    CLI::App* cmd = app.add_subcommand("graph", "Print the frame's compiled render graph: passes in order with their "
                                                "barriers, culled passes and why, resources with size and aliasing");
    cmd->add_option("config", flags->config, "Scene config (JSON)")->required();
    cmd->add_option("--format", flags->format, "text, or dot (Graphviz)")
        ->check(CLI::IsMember({"text", "dot"}))
        ->capture_default_str();
    cmd->add_option("-o,--output", flags->output, "Write to this file instead of stdout");
    addSizeFlags(*cmd, flags->run);
    addParamOverrideFlag(*cmd, flags->run.settings);
    addAllowRootFlag(*cmd, flags->run.allowedRoots);
    addDeviceFlags(*cmd, flags->device);
    return {cmd, [flags] { return runGraph(*flags); }};
}

} // namespace penumbra::app
