// penumbra: the command-line front end. `penumbra render cfg.json -o out.png` renders a
// config headless; `penumbra generate city -o city.glb --set blocks=16` writes a
// procedural scene as glTF; `penumbra validate scene.gltf` loads and repairs a glTF
// file (or checks a config and its plugins) and says what it found; `penumbra plugins`
// lists the technique plugins and their parameters; `penumbra graph cfg.json` prints the
// frame's compiled render graph; `penumbra compare cfg.json` measures each light's
// technique against the reference technique; `penumbra bench cfg.json` runs a config's
// sweep and measures time, memory and error of every variant; `penumbra devices` lists
// the Vulkan devices the loader sees.
#include "BenchCommand.h"
#include "CompareCommand.h"
#include "GraphCommand.h"
#include "PluginsCommand.h"
#include "TimingSummary.h"
#include "penumbra/config/Config.h"
#include "penumbra/config/Overrides.h"
#include "penumbra/core/Error.h"
#include "penumbra/gpu/Context.h"
#include "penumbra/io/Png.h"
#include "penumbra/plugin/PluginRegistry.h"
#include "penumbra/render/FrameRenderer.h"
#include "penumbra/scene/Generators.h"
#include "penumbra/scene/GltfWriter.h"
#include "penumbra/scene/GltfLoader.h"

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <optional>

namespace {

struct DeviceFlags {
    std::string name;
    std::string type;
    bool validation = false;
};

struct RenderFlags {
    std::string config;
    std::string output;
    std::optional<uint32_t> frames;
    uint32_t warmup = 1;
    bool timings = false;
    bool stats = false;
    std::optional<std::string> culling;
    std::optional<uint32_t> width;
    std::optional<uint32_t> height;
    std::vector<std::string> settings;  // technique.param=value
};

struct GenerateFlags {
    std::string generator;
    std::string output;
    std::optional<uint32_t> seed;
    float scale = 1.0f;
    std::vector<std::string> settings;  // key=value
};

struct ValidateFlags {
    std::string file;
    bool weld = false;
    bool verbose = false;
    std::vector<std::string> settings;  // technique.param=value
};

penumbra::gpu::ContextOptions contextOptions(const DeviceFlags& flags)
{
    penumbra::gpu::ContextOptions options;
    options.device.nameContains = flags.name;
    options.device.type = flags.type;
    options = penumbra::gpu::contextOptionsFromEnvironment(options);
    if (flags.validation) options.validation = true;
    return options;
}

// "-o frames/f{frame:04}.png" writes every measured frame; a plain name, the last one.
bool outputPerFrame(const std::string& output) { return output.find("{frame") != std::string::npos; }

std::string framePath(const std::string& pattern, uint32_t frame)
{
    try {
        return fmt::format(fmt::runtime(pattern), fmt::arg("frame", frame));
    } catch (const fmt::format_error& e) {
        throw penumbra::Error(fmt::format("output pattern '{}': {} (use {{frame}} or {{frame:04}})", pattern, e.what()));
    }
}

int runRender(const RenderFlags& flags, const DeviceFlags& deviceFlags)
{
    penumbra::config::RenderConfig loaded = penumbra::config::loadConfig(flags.config);
    penumbra::config::RunOptions options;
    options.overrides = penumbra::config::parseParamOverrides(flags.settings);
    options.width = flags.width;
    options.height = flags.height;
    options.frames = flags.frames;
    if (flags.culling) options.culling = penumbra::config::parseCullingMode(*flags.culling);
    // Fail on a bad output path before spending seconds rendering.
    penumbra::io::checkWritable(outputPerFrame(flags.output) ? framePath(flags.output, 0) : flags.output);

    penumbra::gpu::Context context(contextOptions(deviceFlags));
    spdlog::info("device: {} ({})", context.deviceInfo().name, context.deviceInfo().type);
    penumbra::config::PreparedRun run = penumbra::config::prepareRun(std::move(loaded), options);
    const penumbra::config::RenderConfig& config = run.config;
    penumbra::plugin::PluginRegistry plugins;
    penumbra::render::FrameRenderer renderer(context, run.scene, config, plugins);
    for (const std::string& warning : renderer.warnings()) spdlog::warn("{}", warning);
    spdlog::info("scene: {} instances, {} triangles; {}x{}, {} light(s), {} frame(s)", run.scene.instances.size(),
                 run.scene.triangleCount(), config.width, config.height, config.lights.size(), config.frames);

    // Warm-up frames absorb one-time costs (lavapipe JIT-compiles pipelines at first use).
    const uint32_t warmup = config.frames > 1 ? flags.warmup : 0;
    std::vector<penumbra::render::FrameTimings> measured;
    for (uint32_t i = 0; i < warmup + config.frames; ++i) {
        const uint32_t frame = i < warmup ? 0 : i - warmup;
        if (!config.animation.empty()) renderer.update(config, run.scene, run.poseAtFrame(frame));
        penumbra::render::FrameTimings t = renderer.renderFrame();
        if (i < warmup) continue;
        measured.push_back(std::move(t));
        if (outputPerFrame(flags.output)) {
            penumbra::io::writePng(framePath(flags.output, frame), renderer.width(), renderer.height(), renderer.readColor());
        }
    }
    if (flags.timings) penumbra::app::printTimings(penumbra::app::summarizeTimings(measured));
    if (flags.stats) {
        penumbra::app::printCulling(penumbra::app::medianCulling(measured), penumbra::config::cullingModeName(config.culling));
    }

    if (outputPerFrame(flags.output)) {
        spdlog::info("wrote {} frames: {} ... {}", config.frames, framePath(flags.output, 0),
                     framePath(flags.output, config.frames - 1));
    } else {
        penumbra::io::writePng(flags.output, renderer.width(), renderer.height(), renderer.readColor());
        spdlog::info("wrote {}", flags.output);
    }

    if (context.validationEnabled() && context.validationMessageCount() > 0) {
        spdlog::error("the Vulkan validation layer reported {} message(s)", context.validationMessageCount());
        return 3;
    }
    return 0;
}

double millisecondsSince(std::chrono::steady_clock::time_point start)
{
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

int runGenerate(const GenerateFlags& flags)
{
    namespace scene = penumbra::scene;
    // Unknown generators and bad paths fail before any work.
    const std::vector<scene::GeneratorParameter> known = scene::generatorParameters(flags.generator);
    scene::checkGltfOutput(flags.output);
    if (!(std::isfinite(flags.scale) && flags.scale > 0.0f)) {
        throw penumbra::Error(fmt::format("--scale must be a finite number > 0, got {}", flags.scale));
    }

    std::vector<std::pair<std::string, std::string>> settings;
    if (flags.seed) {
        const bool seeded = std::any_of(known.begin(), known.end(), [](const auto& p) { return p.name == "seed"; });
        if (seeded) settings.emplace_back("seed", std::to_string(*flags.seed));
        else spdlog::warn("generator '{}' makes no random choices: --seed ignored", flags.generator);
    }
    for (const std::string& setting : flags.settings) {
        const size_t eq = setting.find('=');
        if (eq == std::string::npos || eq == 0) {
            throw penumbra::Error(fmt::format("--set '{}': expected name=value, e.g. --set {}={}", setting,
                                              known.front().name, known.front().defaultValue));
        }
        settings.emplace_back(setting.substr(0, eq), setting.substr(eq + 1));
    }

    const auto start = std::chrono::steady_clock::now();
    scene::Scene generated = scene::generateScene(flags.generator, settings);
    scene::scaleScene(generated, flags.scale);
    spdlog::info("generated {} in {:.1f} ms: {} meshes, {} nodes, {} instances, {} triangles", flags.generator,
                 millisecondsSince(start), generated.meshes.size(), generated.graph.size(), generated.instances.size(),
                 generated.triangleCount());
    const auto writeStart = std::chrono::steady_clock::now();
    scene::writeGltf(generated, flags.output);
    spdlog::info("wrote {} in {:.1f} ms", flags.output, millisecondsSince(writeStart));
    return 0;
}

// The generators and their parameters with defaults, for `penumbra generate --help`.
std::string generatorHelp()
{
    std::string text = "Generators and their parameters (defaults; lengths in world units):\n";
    for (const std::string& name : penumbra::scene::generatorNames()) {
        std::vector<std::string> params;
        for (const auto& p : penumbra::scene::generatorParameters(name)) params.push_back(p.name + "=" + p.defaultValue);
        text += fmt::format("  {}: {}\n", name, fmt::join(params, " "));
    }
    return text;
}

void printLight(const penumbra::scene::GltfLight& gltfLight)
{
    const penumbra::scene::Light& l = gltfLight.light;
    fmt::print("light '{}': {}", gltfLight.name, penumbra::scene::lightTypeName(l.type));
    if (l.type != penumbra::scene::LightType::Directional) {
        fmt::print(" at ({:.3g}, {:.3g}, {:.3g})", l.position.x, l.position.y, l.position.z);
    }
    if (l.type != penumbra::scene::LightType::Point) {
        fmt::print(" pointing ({:.3g}, {:.3g}, {:.3g})", l.direction.x, l.direction.y, l.direction.z);
    }
    if (l.type == penumbra::scene::LightType::Spot) fmt::print(", cone {:.3g}..{:.3g} deg", l.innerConeDeg, l.outerConeDeg);
    fmt::print(", intensity {:.4g}, color ({:.3g}, {:.3g}, {:.3g})\n", l.intensity, l.color.r, l.color.g, l.color.b);
}

std::string describeRepair(const penumbra::scene::RepairReport& r)
{
    std::vector<std::string> parts;
    auto add = [&](uint32_t count, const char* what) {
        if (count > 0) parts.push_back(fmt::format("{} {}", count, what));
    };
    add(r.nonFiniteTriangles, "non-finite triangles dropped");
    add(r.degenerateTriangles, "degenerate triangles dropped");
    add(r.unusedVertices, "unused vertices removed");
    add(r.weldedVertices, "vertices welded");
    add(r.generatedNormals, "normals generated");
    add(r.replacedNormals, "NaN normals replaced");
    add(r.renormalizedNormals, "normals normalized");
    std::string text = parts.empty() ? "nothing to repair" : fmt::format("{}", fmt::join(parts, ", "));
    if (r.topologyAnalyzed) {
        text += fmt::format("; {} boundary edges, {} non-manifold triangles", r.boundaryEdges, r.nonManifoldTriangles);
    }
    return text;
}

int runValidateGltf(const ValidateFlags& flags)
{
    penumbra::scene::GltfLoadOptions options;
    options.repair.weld = flags.weld;
    options.repair.analyzeTopology = true;
    // The report lists every warning on stdout; logging them on stderr too would say
    // everything twice.
    if (!flags.verbose) spdlog::set_level(spdlog::level::err);
    penumbra::scene::GltfLoadReport report;
    const penumbra::scene::Scene scene = penumbra::scene::loadGltf(flags.file, report, options);

    size_t meshTriangles = 0;
    for (const auto& mesh : scene.meshes) meshTriangles += mesh.indices.size() / 3;
    fmt::print("{}: {} meshes, {} triangles ({} drawn by {} instances), {} nodes, {} materials, {} textures, {} lights\n",
               flags.file, scene.meshes.size(), meshTriangles, scene.triangleCount(), scene.instances.size(),
               scene.graph.size(), scene.materials.size(), scene.textures.size(), report.lights.size());
    for (const auto& light : report.lights) printLight(light);
    for (size_t i = 0; i < scene.meshes.size(); ++i) {
        const penumbra::scene::Mesh& mesh = scene.meshes[i];
        fmt::print("mesh {} '{}' ({}): {} triangles, {} vertices; {}\n", i, mesh.name, report.meshes[i].element,
                   mesh.indices.size() / 3, mesh.vertices.size(), describeRepair(report.meshes[i].repair));
    }
    for (const std::string& warning : report.warnings) fmt::print("warning: {}\n", warning);
    for (const std::string& note : report.notes) fmt::print("note: {}\n", note);
    fmt::print("ok: {} warnings\n", report.warnings.size());
    return 0;
}

// Checks everything a render would read: includes, every sweep variant, the scene (a
// glTF file is loaded, a generator run), the animation's node tracks, and each light's
// technique plugin with its parameters (--set overrides applied).
int runValidateConfig(const ValidateFlags& flags)
{
    namespace config = penumbra::config;
    config::RunOptions options;
    options.overrides = config::parseParamOverrides(flags.settings);
    const config::ConfigDocument document = config::loadDocument(flags.file);
    const std::vector<config::SweepVariant> variants = config::expandSweep(document);
    const config::PreparedRun run = config::prepareRun(config::parseConfig(document), options);
    const config::RenderConfig& base = run.config;
    const penumbra::scene::Scene& scene = run.scene;
    const config::SceneSource& source = base.scene;
    fmt::print("scene: {} (scale {}): {} meshes, {} instances, {} triangles, {} materials, {} textures\n",
               source.kind == config::SceneSource::Kind::Gltf ? source.gltf.string() : "generator " + source.generator,
               source.scale, scene.meshes.size(), scene.instances.size(), scene.triangleCount(), scene.materials.size(),
               scene.textures.size());
    for (const config::LightConfig& l : base.lights) {
        std::string params;
        for (const config::ShadowParam& p : l.shadow.params) params += fmt::format(" {}={}", p.name, p.value.dump());
        fmt::print("light '{}': {}, intensity {:.4g}, shadow {}{}{}\n", l.name, penumbra::scene::lightTypeName(l.light.type),
                   l.light.intensity, l.shadow.technique, l.shadow.required ? " (required)" : "", params);
    }
    penumbra::plugin::PluginRegistry plugins;
    penumbra::app::PluginCheck pluginCheck;
    pluginCheck.check(base, plugins, true);
    fmt::print("output {}x{}, {} frame(s), culling {}, {} animation track(s) at {} fps\n", base.width, base.height,
               base.frames, config::cullingModeName(base.culling), base.animation.tracks.size(), base.animation.fps);
    if (variants.size() > 1 || !variants.front().label.empty()) {
        fmt::print("sweep: {} variants\n", variants.size());
        for (const config::SweepVariant& v : variants) {
            pluginCheck.check(config::prepareRun(v.config, options).config, plugins, false);
            fmt::print("  {}\n", v.label);
        }
    }
    for (const std::string& warning : pluginCheck.warnings()) fmt::print("warning: {}\n", warning);
    for (const std::string& error : pluginCheck.errors()) fmt::print(stderr, "penumbra: error: {}\n", error);
    if (!pluginCheck.errors().empty()) return 1;
    fmt::print("{}: config ok\n", flags.file);
    return 0;
}

int runValidate(const ValidateFlags& flags)
{
    std::string extension = std::filesystem::path(flags.file).extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    if ((extension == ".gltf" || extension == ".glb") && !flags.settings.empty()) {
        throw penumbra::Error(fmt::format("{}: --set sets technique parameters of a config (.json), not of a glTF file",
                                          flags.file));
    }
    if (extension == ".gltf" || extension == ".glb") return runValidateGltf(flags);
    if (extension == ".json") return runValidateConfig(flags);
    throw penumbra::Error(fmt::format("{}: unknown file type '{}': validate reads .gltf, .glb and .json", flags.file, extension));
}

int runDevices()
{
    const auto devices = penumbra::gpu::Context::listDevices();
    if (devices.empty()) {
        fmt::print(stderr, "penumbra: no Vulkan device found (install mesa-vulkan-drivers for lavapipe)\n");
        return 1;
    }
    for (const auto& d : devices) {
        fmt::print("{} ({}), Vulkan {}.{}.{}, {}\n", d.name, d.type, VK_API_VERSION_MAJOR(d.apiVersion),
                   VK_API_VERSION_MINOR(d.apiVersion), VK_API_VERSION_PATCH(d.apiVersion), d.driverInfo);
    }
    return 0;
}

} // namespace

int main(int argc, char** argv)
{
    // Logs go to stderr so that stdout carries only results (timings) for scripts.
    spdlog::set_default_logger(spdlog::stderr_color_mt("penumbra"));
    spdlog::set_pattern("%^%l%$: %v");
    CLI::App app{"penumbra: real-time shadows, every technique a plugin"};
    app.require_subcommand(1);
    bool verbose = false;
    app.add_flag("-v,--verbose", verbose, "Log debug detail");

    auto addParamOverrideFlag = [](CLI::App* cmd, std::vector<std::string>& settings) {
        cmd->add_option("--set", settings,
                        "Set a technique parameter for every light that uses the technique: --set hard.pcf_kernel=5 "
                        "(repeatable; the value is JSON, or plain text for enum choices; `penumbra plugins` lists them)")
            ->allow_extra_args(false);
    };

    DeviceFlags deviceFlags;
    auto addDeviceFlags = [&](CLI::App* cmd) {
        cmd->add_option("--device", deviceFlags.name,
                        "Use the Vulkan device whose name contains this text (env PENUMBRA_DEVICE)");
        cmd->add_option("--device-type", deviceFlags.type, "Use a device of this type")
            ->check(CLI::IsMember({"discrete", "integrated", "virtual", "cpu"}));
        cmd->add_flag("--validation", deviceFlags.validation,
                      "Enable the Vulkan validation layer; exit 3 if it reports anything (env PENUMBRA_VALIDATION=1)");
    };

    RenderFlags renderFlags;
    CLI::App* render = app.add_subcommand("render", "Render a scene config to a PNG, headless");
    render->add_option("config", renderFlags.config, "Scene config (JSON)")->required();
    render->add_option("-o,--output", renderFlags.output,
                       "Output PNG; a name with {frame} (e.g. f{frame:04}.png) gets every frame")
        ->required();
    render->add_option("--frames", renderFlags.frames, "Frames to render (overrides the config)")
        ->check(CLI::Range(1u, 100000u));
    render->add_option("--warmup", renderFlags.warmup, "Untimed frames before the measured ones (with --frames > 1)")
        ->capture_default_str();
    render->add_flag("--timings", renderFlags.timings, "Print the median GPU and CPU ms of every pass");
    render->add_flag("--stats", renderFlags.stats,
                     "Print the median per-frame culling figures: receivers, casters and triangles drawn, nodes "
                     "visited, queries issued, ms of each step");
    render->add_option("--culling", renderFlags.culling, "Caster culling mode (overrides the config)")
        ->check(CLI::IsMember({"none", "frustum", "light-occlusion", "receiver-mask"}));
    render->add_option("--width", renderFlags.width, "Output width (overrides the config)")->check(CLI::Range(1u, 16384u));
    render->add_option("--height", renderFlags.height, "Output height (overrides the config)")->check(CLI::Range(1u, 16384u));
    addParamOverrideFlag(render, renderFlags.settings);
    addDeviceFlags(render);

    GenerateFlags generateFlags;
    CLI::App* generate = app.add_subcommand("generate", "Write a procedural scene as glTF (.gltf + .bin, or .glb)");
    generate->add_option("generator", generateFlags.generator,
                         fmt::format("One of: {}", fmt::join(penumbra::scene::generatorNames(), ", ")))
        ->required();
    generate->add_option("-o,--output", generateFlags.output, "Output file: .gltf (writes a .bin beside it) or .glb")
        ->required();
    generate->add_option("--seed", generateFlags.seed, "Seed of the generator's random choices");
    generate->add_option("--scale", generateFlags.scale, "Scale the whole scene about the origin (> 0)")
        ->capture_default_str();
    generate->add_option("--set", generateFlags.settings, "Set a generator parameter: --set name=value (repeatable)")
        ->allow_extra_args(false);
    generate->footer(generatorHelp());
    ValidateFlags validateFlags;
    CLI::App* validate = app.add_subcommand("validate", "Load a glTF file (.gltf/.glb) or a config (.json) and report what "
                                                        "was found and repaired; exit 1 with the error if it cannot be loaded");
    validate->add_option("file", validateFlags.file, "glTF file or scene config")->required();
    validate->add_flag("--weld", validateFlags.weld, "Also weld coincident vertices with equal attributes");
    addParamOverrideFlag(validate, validateFlags.settings);

    penumbra::app::PluginsFlags pluginsFlags;
    CLI::App* plugins = app.add_subcommand("plugins", "List the technique plugins on the search path with their parameters, "
                                                      "and every plugin file that fails to load with the reason");
    plugins->add_flag("--json", pluginsFlags.json, "Print a JSON document: {abi, search_path, plugins, errors}");
    plugins->add_option("--path", pluginsFlags.path,
                        "Also search this folder, before $PENUMBRA_PLUGIN_PATH and the build and install trees (repeatable)")
        ->check(CLI::ExistingDirectory)
        ->allow_extra_args(false);
    plugins->add_flag("--strict", pluginsFlags.strict, "Exit 1 when any plugin file fails to load (default: list it, exit 0)");

    CLI::App* devices = app.add_subcommand("devices", "List the Vulkan devices the loader reports");

    penumbra::app::GraphFlags graphFlags;
    CLI::App* graph = app.add_subcommand("graph", "Print the frame's compiled render graph: passes in order with their "
                                                  "barriers, culled passes and why, resources with size and aliasing");
    graph->add_option("config", graphFlags.config, "Scene config (JSON)")->required();
    graph->add_option("--format", graphFlags.format, "text, or dot (Graphviz)")
        ->check(CLI::IsMember({"text", "dot"}))
        ->capture_default_str();
    graph->add_option("-o,--output", graphFlags.output, "Write to this file instead of stdout");
    graph->add_option("--width", graphFlags.width, "Output width (overrides the config)")->check(CLI::Range(1u, 16384u));
    graph->add_option("--height", graphFlags.height, "Output height (overrides the config)")->check(CLI::Range(1u, 16384u));
    addParamOverrideFlag(graph, graphFlags.settings);
    addDeviceFlags(graph);

    // The technique that compare and bench measure against.
    auto addReferenceFlags = [](CLI::App* cmd, std::string& reference, std::vector<std::string>& settings) {
        cmd->add_option("--reference", reference, "The reference technique plugin")->capture_default_str();
        cmd->add_option("--reference-set", settings,
                        "Set a parameter of the reference technique: --reference-set samples=64 (repeatable)")
            ->allow_extra_args(false);
    };

    penumbra::app::CompareFlags compareFlags;
    CLI::App* compare = app.add_subcommand("compare", "Render a config with its techniques and with the reference "
                                                      "technique; print each light's error figures (RMSE, MAE, max, % "
                                                      "wrong, by umbra/penumbra/lit; SSIM) and the colour image's");
    compare->add_option("config", compareFlags.config, "Scene config (JSON)")->required();
    compare->add_option("-o,--output", compareFlags.output,
                        "Write <light>.test.png, <light>.reference.png, <light>.diff.png, color.test.png, "
                        "color.reference.png and metrics.json into this folder (created if missing; other files "
                        "in it are left alone)");
    addReferenceFlags(compare, compareFlags.reference, compareFlags.referenceSettings);
    compare->add_option("--diff-scale", compareFlags.diffScale,
                        "|dV| at which the difference image's colours saturate, in (0, 1]")
        ->capture_default_str();
    compare->add_flag("--json", compareFlags.json, "Print the figures as one JSON document (as metrics.json)");
    compare->add_option("--width", compareFlags.width, "Output width (overrides the config)")->check(CLI::Range(1u, 16384u));
    compare->add_option("--height", compareFlags.height, "Output height (overrides the config)")->check(CLI::Range(1u, 16384u));
    addParamOverrideFlag(compare, compareFlags.settings);
    addDeviceFlags(compare);

    penumbra::app::BenchFlags benchFlags;
    benchFlags.command.assign(argv, argv + argc);
    CLI::App* bench = app.add_subcommand("bench", "Run a config's sweep (techniques x parameters x scenes x lights): "
                                                  "GPU and CPU time per pass, memory per technique and each light's "
                                                  "error against the reference technique; write CSV, JSON and a Pareto plot");
    bench->add_option("config", benchFlags.config, "Scene config (JSON) with a \"sweep\"")->required();
    bench->add_option("-o,--output", benchFlags.output,
                      "Write results.csv, results.json and pareto.svg into this folder (created if missing; other "
                      "files in it are left alone)");
    bench->add_option("--summary", benchFlags.summary, "Also write the results as a Markdown summary to this file");
    bench->add_option("--frames", benchFlags.frames, "Measured frames per variant (medians)")
        ->check(CLI::Range(1u, 100000u))
        ->capture_default_str();
    bench->add_option("--warmup", benchFlags.warmup, "Untimed frames before the measured ones, per variant")
        ->check(CLI::Range(0u, 100000u))
        ->capture_default_str();
    addReferenceFlags(bench, benchFlags.reference, benchFlags.referenceSettings);
    bench->add_option("--width", benchFlags.width, "Output width (overrides every variant)")->check(CLI::Range(1u, 16384u));
    bench->add_option("--height", benchFlags.height, "Output height (overrides every variant)")->check(CLI::Range(1u, 16384u));
    addParamOverrideFlag(bench, benchFlags.settings);
    addDeviceFlags(bench);

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e);
    }
    if (verbose) spdlog::set_level(spdlog::level::debug);
    validateFlags.verbose = verbose;

    try {
        if (render->parsed()) return runRender(renderFlags, deviceFlags);
        if (generate->parsed()) return runGenerate(generateFlags);
        if (validate->parsed()) return runValidate(validateFlags);
        if (devices->parsed()) return runDevices();
        if (graph->parsed()) return penumbra::app::runGraph(graphFlags, contextOptions(deviceFlags));
        if (compare->parsed()) return penumbra::app::runCompare(compareFlags, contextOptions(deviceFlags));
        if (bench->parsed()) return penumbra::app::runBench(benchFlags, contextOptions(deviceFlags));
        if (plugins->parsed()) return penumbra::app::runPlugins(pluginsFlags);
    } catch (const penumbra::Error& e) {
        fmt::print(stderr, "penumbra: error: {}\n", e.what());
        return 1;
    } catch (const std::exception& e) {
        fmt::print(stderr, "penumbra: internal error: {}\n", e.what());
        return 2;
    }
    return 0;
}
