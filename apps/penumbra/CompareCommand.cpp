#include "CompareCommand.h"

#include "FrameCapture.h"
#include "OutputFolder.h"
#include "ReferenceTechnique.h"
#include "VisibilityExr.h"

#include "penumbra/config/Run.h"
#include "penumbra/core/Error.h"
#include "penumbra/core/ShortText.h"
#include "penumbra/frame/FrameRenderer.h"
#include "penumbra/frame/SceneResources.h"
#include "penumbra/io/Png.h"
#include "penumbra/io/StagedFile.h"
#include "penumbra/metrics/DifferenceImage.h"
#include "penumbra/metrics/ImageComparison.h"
#include "penumbra/plugin/PluginRegistry.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <cctype>
#include <chrono>
#include <memory>
#include <set>

using nlohmann::json;
namespace fs = std::filesystem;

namespace penumbra::app {
namespace {

struct CompareFlags {
    std::string config;
    std::string referenceExr;  // a second file: `compare A.exr B.exr` compares two OpenEXR files
    std::string output;  // -o DIR; empty: print the figures only
    ReferenceFlags reference;
    RunFlags run;        // --set: the test render's techniques
    bool json = false;   // print the JSON document instead of the table
    double diffScale = metrics::kDefaultDifferenceFullScale;  // --diff-scale: |ΔV| of full colour
    DeviceFlags device;
};

// Renders one frame of `config` and reads back what the comparison needs. The renderer
// is gone when this returns, so that the two renders never hold their techniques' device
// memory together; the scene's (`scene`: upload, BVH, the engine's pipelines) is shared.
FrameImages renderOnce(const std::shared_ptr<frame::SceneResources>& scene, const config::RenderConfig& config,
                       plugin::PluginRegistry& plugins, const char* label, std::vector<std::string>& warnings)
{
    frame::FrameRenderer renderer(scene, config, plugins);
    for (const std::string& warning : renderer.warnings()) {
        spdlog::warn("{} render: {}", label, warning);
        warnings.push_back(fmt::format("{} render: {}", label, warning));
    }
    const auto start = std::chrono::steady_clock::now();
    renderer.renderFrame();
    spdlog::info("{} render: {:.0f} ms", label,
                 std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
    return captureFrame(renderer);
}

// File names for each light's images: its name where that is a plain file name, else
// with every other character as '_'; a name already taken (two lights that map to one
// name, or "color", the colour images') gets "-light<i>".
std::vector<std::string> lightFileStems(const config::RenderConfig& config)
{
    std::set<std::string> taken{"color"};
    std::vector<std::string> stems;
    for (size_t i = 0; i < config.lights.size(); ++i) {
        std::string stem = config.lights[i].name;
        for (char& c : stem) {
            if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.')) c = '_';
        }
        if (stem.empty() || stem.front() == '.') stem.insert(stem.begin(), '_');
        if (taken.count(stem)) stem += fmt::format("-light{}", i);
        taken.insert(stem);
        stems.push_back(std::move(stem));
    }
    return stems;
}

struct OutputFiles {
    struct Light {
        fs::path test, reference, diff;
    };
    std::vector<Light> lights;
    fs::path colorTest, colorReference, metrics;
    fs::path visibilityTest, visibilityReference;  // every light's V as floats (VisibilityExr.h)

    std::vector<fs::path> all() const
    {
        std::vector<fs::path> files;
        for (const Light& l : lights) files.insert(files.end(), {l.test, l.reference, l.diff});
        files.insert(files.end(), {colorTest, colorReference, visibilityTest, visibilityReference, metrics});
        return files;
    }
};

OutputFiles outputFiles(const fs::path& dir, const config::RenderConfig& config)
{
    OutputFiles files;
    for (const std::string& stem : lightFileStems(config)) {
        files.lights.push_back({dir / (stem + ".test.png"), dir / (stem + ".reference.png"), dir / (stem + ".diff.png")});
    }
    files.colorTest = dir / "color.test.png";
    files.colorReference = dir / "color.reference.png";
    files.visibilityTest = dir / "visibility.test.exr";
    files.visibilityReference = dir / "visibility.reference.exr";
    files.metrics = dir / "metrics.json";
    return files;
}

std::string percent(double value) { return fmt::format("{:.2f}%", value); }

void printStatsRow(const std::string& label, const metrics::ErrorStats& s)
{
    const std::string where = s.pixels > 0 ? fmt::format("({}, {})", s.maxX, s.maxY) : "-";
    std::string above;
    for (size_t t = 0; t < metrics::kErrorThresholds.size(); ++t) above += fmt::format(" {:>8}", percent(s.percentAbove(t)));
    fmt::print("  {:<9} {:>9} {:>9.5f} {:>9.5f} {:>9.5f} {:>12}{}\n", label, s.pixels, s.rmse, s.mae, s.maxAbsError, where,
               above);
}

void printStatsHeader()
{
    std::string above;
    for (double t : metrics::kErrorThresholds) above += fmt::format(" {:>8}", fmt::format(">{}", t));
    fmt::print("  {:<9} {:>9} {:>9} {:>9} {:>9} {:>12}{}\n", "region", "pixels", "RMSE", "MAE", "max", "max at", above);
}

// One visibility image's figures: the rows by region, SSIM, and any invalid values.
void printVisibility(const metrics::VisibilityComparison& c)
{
    printStatsHeader();
    printStatsRow("all", c.all);
    for (size_t r = 0; r < metrics::kRegionCount; ++r) printStatsRow(metrics::regionName(metrics::Region(r)), c.regions[r]);
    fmt::print("  SSIM {:.5f}\n", c.ssim);
    if (c.test.total() + c.reference.total() > 0) {
        fmt::print("  invalid values: test {} non-finite (left out), {} outside [0, 1]; reference {} non-finite, {} "
                   "outside [0, 1]\n",
                   c.test.nonFinite, c.test.outOfRange, c.reference.nonFinite, c.reference.outOfRange);
    }
}

void printTable(const json& doc, const std::vector<metrics::VisibilityComparison>& lights,
                const metrics::ColorComparison& color)
{
    fmt::print("compare {}: {}x{}, {} geometry pixels; reference technique {} {}\n", doc["config"].get<std::string>(),
               color.width, color.height, color.geometryPixels, doc["reference"]["technique"].get<std::string>(),
               doc["reference"]["params"].dump());
    fmt::print("regions of the reference: umbra V <= {}, lit V >= {}, penumbra between\n", metrics::kUmbraMaxVisibility,
               metrics::kLitMinVisibility);
    for (size_t i = 0; i < lights.size(); ++i) {
        const json& light = doc["lights"][i];
        const metrics::VisibilityComparison& c = lights[i];
        fmt::print("\nlight {} '{}': {} {}\n", i, light["name"].get<std::string>(), light["technique"].get<std::string>(),
                   light["params"].dump());
        printVisibility(c);
    }
    fmt::print("\ncolour (sRGB values in [0, 1], averaged over R, G, B):\n");
    printStatsHeader();
    printStatsRow("all", color.all);
    fmt::print("  SSIM (luma) {:.5f}\n", color.ssimLuma);
}

// `reaches`: per light, the pixels compared (reachMask); the others are grey in its diff.
void writeOutputs(const OutputFiles& files, const FrameImages& test, const FrameImages& reference,
                  const std::vector<config::LightConfig>& lights, const std::vector<metrics::PixelMask>& reaches,
                  float diffScale, const json& doc)
{
    const uint32_t w = test.width, h = test.height;
    for (size_t i = 0; i < files.lights.size(); ++i) {
        const metrics::FloatImageView v{w, h, test.visibility[i]}, vRef{w, h, reference.visibility[i]};
        io::writePng(files.lights[i].test, w, h, metrics::visibilityGreyscale(v));
        io::writePng(files.lights[i].reference, w, h, metrics::visibilityGreyscale(vRef));
        io::writePng(files.lights[i].diff, w, h, metrics::differenceImage(v, vRef, &reaches[i], diffScale));
    }
    io::writePng(files.colorTest, w, h, test.color);
    io::writePng(files.colorReference, w, h, reference.color);
    writeVisibilityExr(files.visibilityTest, w, h, lights, test.visibility);
    writeVisibilityExr(files.visibilityReference, w, h, lights, reference.visibility);
    io::writeTextFile(files.metrics, doc.dump(2) + "\n");
}

int runCompare(const CompareFlags& flags)
{
    if (!(flags.diffScale > 0.0f && flags.diffScale <= 1.0f)) {
        throw Error(fmt::format("--diff-scale must be in (0, 1], got {}", flags.diffScale));
    }
    config::RenderConfig loaded = loadConfigIgnoringSweep(flags.config, "compare");
    const config::RunOptions options = runOptions(flags.run);

    plugin::PluginRegistry plugins;
    const ReferenceTechnique reference = loadReferenceTechnique(flags.reference.technique, flags.reference.settings, plugins);
    config::PreparedRun run = config::prepareRun(std::move(loaded), options);
    checkPluginsBeforeDevice(run.config, options, plugins);
    run.poseAtFrame(0);  // an animated config is measured at its first frame, as `render` shows it
    const config::RenderConfig& config = run.config;
    const scene::Scene& scene = run.scene;
    const config::RenderConfig referenceConfig = withReferenceShadows(config, reference);

    const fs::path dir = outputFolder(flags.output);
    const OutputFiles files = outputFiles(dir, config);
    if (!flags.output.empty()) checkOutputFolder(dir, files.all(), fmt::format("-o {}", dir.string()));

    gpu::Context context(contextOptions(flags.device));
    spdlog::info("device: {} ({})", context.deviceInfo().name, context.deviceInfo().type);
    std::vector<std::string> warnings;
    const auto resources =
        std::make_shared<frame::SceneResources>(context, scene, frame::SceneResources::batchingOf(config));
    const FrameImages test = renderOnce(resources, config, plugins, "test", warnings);
    const FrameImages ref = renderOnce(resources, referenceConfig, plugins, "reference", warnings);

    // Both renders drew the same scene from the same camera: one G-buffer's coverage.
    const metrics::PixelMask mask = metrics::geometryMask(ref.width, ref.height, ref.positions);
    const uint32_t w = test.width, h = test.height;
    std::vector<metrics::VisibilityComparison> comparisons;
    json doc = {{"config", flags.config},
                {"width", w},
                {"height", h},
                {"reference", {{"technique", flags.reference.technique}, {"params", reference.params}}},
                {"lights", json::array()}};
    std::vector<metrics::PixelMask> reaches;
    for (size_t i = 0; i < config.lights.size(); ++i) {
        reaches.push_back(reachMask(config.lights[i].light, ref.width, ref.height, ref.positions));
        comparisons.push_back(
            metrics::compareVisibility({w, h, test.visibility[i]}, {w, h, ref.visibility[i]}, &reaches.back()));
        const metrics::VisibilityComparison& c = comparisons.back();
        const std::string& technique = test.techniques[i];
        json light = {{"index", i},
                      {"name", config.lights[i].name},
                      {"technique", technique.empty() ? "unshadowed" : technique},
                      {"params", technique.empty() || config.lights[i].shadow.unshadowed()
                                     ? json(nullptr)
                                                   : plugin::resolveParams(plugins.load(technique), config.lights[i].shadow).toJson()},
                      {"visibility", metrics::toJson(c)}};
        if (!flags.output.empty()) {
            light["files"] = {{"test", files.lights[i].test.filename().string()},
                              {"reference", files.lights[i].reference.filename().string()},
                              {"diff", files.lights[i].diff.filename().string()},
                              {"channel", visibilityChannel(config.lights[i].name)}};
        }
        doc["lights"].push_back(std::move(light));
        if (c.test.total() > 0) {
            warnings.push_back(fmt::format("light {} ('{}'): the test image has {} non-finite value(s) (left out of the "
                                           "figures) and {} outside [0, 1]",
                                           i, config.lights[i].name, c.test.nonFinite, c.test.outOfRange));
            spdlog::warn("{}", warnings.back());
        }
    }
    const metrics::ColorComparison color = metrics::compareColor({w, h, test.color}, {w, h, ref.color}, &mask);
    doc["color"] = metrics::toJson(color);
    if (!flags.output.empty()) {
        doc["color"]["files"] = {{"test", files.colorTest.filename().string()},
                                 {"reference", files.colorReference.filename().string()}};
        doc["visibility_files"] = {{"test", files.visibilityTest.filename().string()},
                                   {"reference", files.visibilityReference.filename().string()}};
    }
    doc["diff_scale"] = flags.diffScale;
    doc["warnings"] = warnings;

    // Files first: figures on stdout mean that the files, if asked for, are there too.
    if (!flags.output.empty()) {
        // Into a staging folder that then takes the folder's place: all or nothing.
        OutputSet set(dir, fmt::format("-o {}", dir.string()));
        writeOutputs(outputFiles(set.folder(), config), test, ref, config.lights, reaches, float(flags.diffScale), doc);
        set.commit();
        spdlog::info("wrote {} files into {}", files.all().size(), dir.string());
    }
    if (flags.json) {
        fmt::print("{}\n", doc.dump(2));
    } else {
        printTable(doc, comparisons, color);
    }

    return validationExitCode(context);
}

// `compare A.exr B.exr`: every channel of A against B's (B the reference).
int compareExrFiles(const CompareFlags& flags)
{
    const ExrImage test = readExr(flags.config), reference = readExr(flags.referenceExr);
    const std::vector<ExrChannelComparison> comparisons = compareExrChannels(test, flags.config, reference, flags.referenceExr);
    if (flags.json) {
        json doc = {{"test", flags.config}, {"reference", flags.referenceExr}, {"width", test.width}, {"height", test.height},
                    {"channels", json::array()}};
        for (const ExrChannelComparison& c : comparisons) {
            doc["channels"].push_back({{"name", c.channel}, {"visibility", metrics::toJson(c.visibility)}});
        }
        fmt::print("{}\n", doc.dump(2));
        return 0;
    }
    fmt::print("compare {} against the reference {}: {}x{}, every pixel\n", flags.config, flags.referenceExr, test.width,
               test.height);
    fmt::print("regions of the reference: umbra V <= {}, lit V >= {}, penumbra between\n", metrics::kUmbraMaxVisibility,
               metrics::kLitMinVisibility);
    for (const ExrChannelComparison& c : comparisons) {
        fmt::print("\nchannel '{}'{}\n", c.channel,
                   c.channel == kFirstLightLumaChannel ? " (in penumbra's files: the first light's V again)" : "");
        printVisibility(c.visibility);
    }
    return 0;
}

// Which of the two forms the arguments ask for; the config form's flags mean nothing to two
// files and are refused rather than ignored.
int runCompareCommand(const CLI::App& cmd, const CompareFlags& flags)
{
    const bool firstIsExr = fs::path(flags.config).extension() == ".exr";
    if (flags.referenceExr.empty()) {
        if (firstIsExr) throw Error(fmt::format("compare {}: two OpenEXR files are compared (compare A.exr B.exr)", core::shortText(flags.config)));
        return runCompare(flags);
    }
    for (const CLI::Option* option : cmd.get_options()) {
        if (option->count() > 0 && option->nonpositional() && option->get_name() != "--json") {
            throw Error(fmt::format("compare A.exr B.exr takes only --json; {} belongs to compare CONFIG.json", option->get_name()));
        }
    }
    return compareExrFiles(flags);
}

} // namespace

Command addCompareCommand(CLI::App& app)
{
    auto flags = std::make_shared<CompareFlags>();
    CLI::App* cmd = app.add_subcommand("compare", "Render a config with its techniques and with the reference "
                                                  "technique; print each light's error figures (RMSE, MAE, max, % "
                                                  "wrong, by umbra/penumbra/lit; SSIM) and the colour image's. Or, "
                                                  "given two OpenEXR files, the same figures per channel");
    cmd->add_option("config", flags->config, "Scene config (JSON); or A.exr, compared with B.exr after it")->required();
    cmd->add_option("reference_exr", flags->referenceExr,
                    "B.exr: with A.exr, compare every channel of two OpenEXR files (visibility EXRs), B the reference");
    cmd->add_option("-o,--output", flags->output,
                    "Write <light>.test.png, <light>.reference.png, <light>.diff.png, color.test.png, "
                    "color.reference.png, visibility.test.exr and visibility.reference.exr (every light's V as "
                    "32-bit floats, one channel \"<light name>.V\" each, and Y: the first light's V again) and metrics.json into this folder "
                    "(created if missing; other files in it are left alone)");
    addReferenceFlags(*cmd, flags->reference);
    cmd->add_option("--diff-scale", flags->diffScale, "|dV| at which the difference image's colours saturate, in (0, 1]")
        ->capture_default_str();
    cmd->add_flag("--json", flags->json, "Print the figures as one JSON document (as metrics.json)");
    addSizeFlags(*cmd, flags->run);
    addParamOverrideFlag(*cmd, flags->run.settings);
    addAllowRootFlag(*cmd, flags->run.allowedRoots);
    addDeviceFlags(*cmd, flags->device);
    return {cmd, [flags, cmd] { return runCompareCommand(*cmd, *flags); }};
}

} // namespace penumbra::app
