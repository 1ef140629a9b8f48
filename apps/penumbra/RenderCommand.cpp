#include "RenderCommand.h"

#include "FloorComparison.h"
#include "Phase.h"
#include "TimingSummary.h"
#include "VisibilityExr.h"
#include "penumbra/config/Run.h"
#include "penumbra/core/Error.h"
#include "penumbra/core/ShortText.h"
#include "penumbra/frame/FloorRenderer.h"
#include "penumbra/frame/FrameRenderer.h"
#include "penumbra/gpu/ShaderCache.h"
#include "penumbra/io/Png.h"
#include "penumbra/metrics/DebugImage.h"
#include "penumbra/plugin/PluginRegistry.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <cmath>
#include <cstdlib>
#include <memory>
#include <optional>

namespace penumbra::app {
namespace {

struct RenderFlags {
    std::string config;
    std::string output;
    std::string visibilityExr;
    std::optional<uint32_t> frames;
    std::optional<uint32_t> warmup;
    bool timings = false;
    bool stats = false;
    std::optional<std::string> culling;
    std::optional<bool> keepUnchanged;
    std::string debugImage;       // --debug-image: the output shows this graph image instead of the colour
    std::string debugMapping = "linear";
    std::string debugRange;       // "MIN,MAX"; empty: the image's finite values
    RunFlags run;
    DeviceFlags device;
};

// --debug-range "MIN,MAX": finite, MIN <= MAX.
std::optional<metrics::DebugRange> parseDebugRange(const std::string& text)
{
    if (text.empty()) return std::nullopt;
    const size_t comma = text.find(',');
    metrics::DebugRange range;
    char* end = nullptr;
    bool ok = comma != std::string::npos;
    if (ok) {
        const std::string low = text.substr(0, comma), high = text.substr(comma + 1);
        range.min = std::strtod(low.c_str(), &end);
        ok = !low.empty() && *end == '\0';
        range.max = std::strtod(high.c_str(), &end);
        ok = ok && !high.empty() && *end == '\0';
    }
    if (!ok || !std::isfinite(range.min) || !std::isfinite(range.max) || range.min > range.max) {
        throw Error(fmt::format("--debug-range '{}': expected MIN,MAX, two finite numbers with MIN <= MAX",
                                core::shortText(text)));
    }
    return range;
}

// The image file of a frame (PNG or JPEG, as its name says): its colour image, or the
// requested debug image mapped to RGBA8.
void writeFrameImage(const std::string& path, const frame::FrameRenderer& renderer, const RenderFlags& flags)
{
    if (flags.debugImage.empty()) {
        io::writeImage(path, renderer.width(), renderer.height(), renderer.readColor());
        return;
    }
    const metrics::DebugMapping mapping = metrics::parseDebugMapping(flags.debugMapping);
    const metrics::DebugImageValues image = renderer.readImage(flags.debugImage);
    const metrics::DebugRange found = metrics::finiteRange(image, mapping);
    const metrics::DebugRange range = parseDebugRange(flags.debugRange).value_or(found);
    io::writeImage(path, image.width, image.height, metrics::debugImageRgba(image, mapping, range));
    spdlog::info("debug image '{}': {} x {}, {} channel(s), values in [{}, {}]{}; shown {} over [{}, {}]", flags.debugImage,
                 image.width, image.height, image.channels, found.min, found.max,
                 found.nonFinite ? fmt::format(" and {} non-finite (magenta)", found.nonFinite) : "",
                 metrics::debugMappingName(mapping), range.min, range.max);
}

// What the shaders of this run cost: compiled by glslang, or found in the SPIR-V cache.
void printShaderCache()
{
    const gpu::ShaderCache& cache = gpu::ShaderCache::shared();
    const gpu::ShaderCacheStats s = cache.stats();
    fmt::print("shaders ({})\n", cache.folder().empty() ? "cache in memory only" : "cache " + cache.folder().string());
    fmt::print("  {:<39}{}\n", "compiled", s.compiled);
    fmt::print("  {:<39}{}\n", "found in memory", s.memoryHits);
    fmt::print("  {:<39}{}\n", "found on disk", s.diskHits);
    fmt::print("  {:<39}{}\n", "damaged cache files ignored", s.damagedFiles);
}

// "-o frames/f{frame:04}.png" writes every measured frame; a plain name, the last one.
bool outputPerFrame(const std::string& output) { return output.find("{frame") != std::string::npos; }

std::string framePath(const std::string& pattern, uint32_t frame)
{
    try {
        return fmt::format(fmt::runtime(pattern), fmt::arg("frame", frame));
    } catch (const fmt::format_error& e) {
        throw Error(fmt::format("output pattern '{}': {} (use {{frame}} or {{frame:04}})", core::shortText(pattern),
                                e.what()));
    }
}

int runRender(const RenderFlags& flags)
{
    config::RenderConfig loaded =
        inPhase("loading the config", [&] { return loadConfigIgnoringSweep(flags.config, "render"); });
    config::RunOptions options = runOptions(flags.run);
    options.frames = flags.frames;
    if (flags.culling) options.culling = config::parseCullingMode(*flags.culling);
    options.keepUnchanged = flags.keepUnchanged;
    // Fail on a bad output path or image name before spending seconds rendering.
    const std::string firstOutput = outputPerFrame(flags.output) ? framePath(flags.output, 0) : flags.output;
    io::imageFormatFor(firstOutput);
    io::checkWritable(firstOutput);
    if (!flags.visibilityExr.empty()) io::checkWritable(flags.visibilityExr);
    metrics::parseDebugMapping(flags.debugMapping);
    parseDebugRange(flags.debugRange);

    config::PreparedRun run = inPhase("loading the scene", [&] { return config::prepareRun(std::move(loaded), options); });
    plugin::PluginRegistry plugins;
    checkPluginsBeforeDevice(run.config, options, plugins);

    gpu::Context context(contextOptions(flags.device));
    spdlog::info("device: {} ({})", context.deviceInfo().name, context.deviceInfo().type);
    frame::FrameRenderer renderer(context, run.scene, run.config, plugins);
    for (const std::string& warning : renderer.warnings()) spdlog::warn("{}", warning);
    // Nothing but shading reads the lights' V_l unless an image of them is asked for:
    // shading then evaluates the visibility functions itself (plugin/VisibilityFunction.h).
    renderer.setVisibilityReadBack(!flags.visibilityExr.empty() || !flags.debugImage.empty());
    if (!flags.debugImage.empty()) renderer.requestImage(flags.debugImage);
    const config::RenderConfig& resolved = run.rest;
    spdlog::info("scene: {} instances, {} triangles; {}x{}, {} light(s), {} frame(s)", run.scene.instances.size(),
                 run.scene.triangleCount(), resolved.width, resolved.height, resolved.lights.size(), resolved.frames);

    // Warm-up frames absorb one-time costs (lavapipe JIT-compiles pipelines at first use):
    // as many as --warmup asks for, at any frame count; without it, one when measuring
    // (several frames or --timings), none for a plain still.
    const uint32_t warmup = flags.warmup.value_or(run.config.frames > 1 || flags.timings ? 1u : 0u);
    spdlog::info("{} warm-up frame(s), {} measured", warmup, run.config.frames);
    // With --timings the floor (frame/FloorRenderer.h) is drawn after every frame, with the
    // frame's pose, so that both are measured side by side under the same load.
    std::unique_ptr<frame::FloorRenderer> floor;
    if (flags.timings) floor = std::make_unique<frame::FloorRenderer>(context, run.scene, run.config);
    std::vector<frame::FrameTimings> measured, floorMeasured;
    for (uint32_t i = 0; i < warmup + run.config.frames; ++i) {
        const uint32_t frame = i < warmup ? 0 : i - warmup;
        if (config::animated(run.config)) {
            const std::vector<uint32_t> moved = run.poseAtFrame(frame);
            renderer.update(run.config, run.scene, moved);
            if (floor) floor->update(run.config, run.scene, moved);
        }
        frame::FrameTimings t = renderer.renderFrame();
        if (i < warmup) {
            if (floor) floor->renderFrame();
            continue;
        }
        measured.push_back(std::move(t));
        if (outputPerFrame(flags.output)) {
            writeFrameImage(framePath(flags.output, frame), renderer, flags);
        }
        if (floor) floorMeasured.push_back(floor->renderFrame());
    }
    if (flags.timings) {
        const TimingSummary frameSummary = summarizeTimings(measured);
        const FloorComparison comparison =
            compareWithFloor(frameSummary, cameraPasses(*renderer.executor().compiled(), renderer.width(), renderer.height()),
                             summarizeFloor(floorMeasured, resolved.lights.size()), anyLightShadowed(renderer));
        printTimings(frameSummary, warmup, &comparison);
        std::fputs(lightFatesText(measured, run.config.lights).c_str(), stdout);
    }
    if (flags.stats) {
        printCulling(medianCulling(measured), config::cullingModeName(run.config.culling));
        if (!flags.timings) std::fputs(lightFatesText(measured, run.config.lights).c_str(), stdout);
        std::vector<std::string> techniques;
        for (size_t l = 0; l < renderer.lightCount(); ++l) techniques.push_back(renderer.techniqueName(l));
        std::fputs(techniqueFiguresText(medianTechniqueFigures(measured), techniques).c_str(), stdout);
        printShaderCache();
    }

    if (outputPerFrame(flags.output)) {
        spdlog::info("wrote {} frames: {} ... {}", run.config.frames, framePath(flags.output, 0),
                     framePath(flags.output, run.config.frames - 1));
    } else {
        writeFrameImage(flags.output, renderer, flags);
        spdlog::info("wrote {}", flags.output);
    }
    if (!flags.visibilityExr.empty()) {
        std::vector<std::vector<float>> visibility;
        for (size_t l = 0; l < run.config.lights.size(); ++l) visibility.push_back(renderer.readVisibility(l));
        writeVisibilityExr(flags.visibilityExr, renderer.width(), renderer.height(), run.config.lights, visibility);
        spdlog::info("wrote {} (V of {} light(s), 32-bit float)", flags.visibilityExr, visibility.size());
    }

    return validationExitCode(context);
}

} // namespace

Command addRenderCommand(CLI::App& app)
{
    auto flags = std::make_shared<RenderFlags>();
    CLI::App* cmd = app.add_subcommand("render", "Render a scene config to a PNG or JPEG image, headless");
    cmd->add_option("config", flags->config, "Scene config (JSON)")->required();
    cmd->add_option("-o,--output", flags->output, "Output image, .png or .jpg (.jpeg); a name with {frame} (e.g. f{frame:04}.png) gets every "
                    "frame")
        ->required();
    cmd->add_option("--visibility-exr", flags->visibilityExr,
                    "Also write every light's visibility image V (the last frame's) as 32-bit floats: an OpenEXR "
                    "file with one channel per light, \"<light name>.V\", and \"Y\": the first light's V again, which "
                    "image viewers show");
    cmd->add_option("--frames", flags->frames, "Frames to render (overrides the config)")->check(CLI::Range(1u, 100000u));
    cmd->add_option("--warmup", flags->warmup,
                    "Untimed frames before the measured ones (default: 1 with --frames > 1 or --timings, else 0)")
        ->check(CLI::Range(0u, 100000u));
    cmd->add_flag("--timings", flags->timings,
                  "Print the median GPU and CPU ms of every pass, and each as a multiple of the floor (the scene "
                  "drawn once forward)");
    cmd->add_flag("--stats", flags->stats,
                  "Print the median per-frame culling figures (receivers, casters and triangles drawn, nodes "
                  "visited, queries issued, ms of each step), each light's technique figures (a deep shadow "
                  "map's fragments, pool and depth complexity) and the shaders compiled or found in the SPIR-V "
                  "cache");
    cmd->add_option("--culling", flags->culling, "Caster culling mode (overrides the config)")
        ->check(CLI::IsMember({"none", "frustum", "light-occlusion", "receiver-mask"}));
    cmd->add_option("--keep-unchanged", flags->keepUnchanged,
                    "true: passes whose light, casters, camera and inputs did not change keep their results (a still "
                    "frame runs nothing; --timings says \"kept\"); false: every pass runs every frame, to time a still "
                    "frame's work (overrides the config's keep_unchanged, default true)");
    cmd->add_option("--debug-image", flags->debugImage,
                    "Write this image of the frame's graph to the output instead of the colour (a shadow map, a moment "
                    "map, a visibility image: `penumbra graph CONFIG` lists them); its passes run even where nothing "
                    "else reads it");
    cmd->add_option("--debug-map", flags->debugMapping, "How --debug-image maps values: linear, log or false-color")
        ->capture_default_str();
    cmd->add_option("--debug-range", flags->debugRange,
                    "The values --debug-image maps to black and white, MIN,MAX (default: its finite values' range)");
    addSizeFlags(*cmd, flags->run);
    addParamOverrideFlag(*cmd, flags->run.settings);
    addAllowRootFlag(*cmd, flags->run.allowedRoots);
    addDeviceFlags(*cmd, flags->device);
    return {cmd, [flags] { return runRender(*flags); }};
}

} // namespace penumbra::app
