#include "GraphCommand.h"

#include "penumbra/config/Run.h"
#include "penumbra/core/Error.h"
#include "penumbra/io/StagedFile.h"
#include "penumbra/plugin/PluginRegistry.h"
#include "penumbra/render/FrameRenderer.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <cstdio>

namespace penumbra::app {
namespace {

std::string mebibytes(VkDeviceSize bytes) { return fmt::format("{:.2f} MiB", double(bytes) / (1024.0 * 1024.0)); }

} // namespace

int runGraph(const GraphFlags& flags, const gpu::ContextOptions& device)
{
    config::RenderConfig loaded = config::loadConfig(flags.config);
    config::RunOptions options;
    options.overrides = config::parseParamOverrides(flags.settings);
    options.width = flags.width;
    options.height = flags.height;
    if (!flags.output.empty()) io::checkWritable(flags.output);

    gpu::Context context(device);
    const config::PreparedRun run = config::prepareRun(std::move(loaded), options);
    plugin::PluginRegistry plugins;
    render::FrameRenderer renderer(context, run.scene, run.config, plugins);
    for (const std::string& warning : renderer.warnings()) spdlog::warn("{}", warning);
    renderer.renderFrame();

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

} // namespace penumbra::app
