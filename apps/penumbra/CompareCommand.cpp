#include "CompareCommand.h"

#include "penumbra/config/Config.h"
#include "penumbra/config/Overrides.h"
#include "penumbra/core/Error.h"
#include "penumbra/io/Png.h"
#include "penumbra/io/StagedFile.h"
#include "penumbra/metrics/ImageComparison.h"
#include "penumbra/plugin/PluginRegistry.h"
#include "penumbra/render/FrameRenderer.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <cctype>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <set>

using nlohmann::json;
namespace fs = std::filesystem;

namespace penumbra::app {
namespace {

// What one render leaves for the comparison.
struct FrameImages {
    uint32_t width = 0;
    uint32_t height = 0;
    std::vector<uint8_t> color;                  // sRGB RGBA8
    std::vector<std::vector<float>> visibility;  // V_l per light
    std::vector<float> positions;                // G-buffer world positions (w = 0: background)
    std::vector<std::string> techniques;         // per light; empty: rendered unshadowed (fallback)
};

// Renders one frame of `config` and reads back what the comparison needs. The renderer
// is gone when this returns, so that the two renders never hold device memory together.
FrameImages renderOnce(gpu::Context& context, const scene::Scene& scene, const config::RenderConfig& config,
                       plugin::PluginRegistry& plugins, const char* label, std::vector<std::string>& warnings)
{
    render::FrameRenderer renderer(context, scene, config, plugins);
    for (const std::string& warning : renderer.warnings()) {
        spdlog::warn("{} render: {}", label, warning);
        warnings.push_back(fmt::format("{} render: {}", label, warning));
    }
    const auto start = std::chrono::steady_clock::now();
    renderer.renderFrame();
    spdlog::info("{} render: {:.0f} ms", label,
                 std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
    FrameImages images;
    images.width = renderer.width();
    images.height = renderer.height();
    images.color = renderer.readColor();
    images.positions = renderer.readPositions();
    for (size_t i = 0; i < renderer.lightCount(); ++i) {
        images.visibility.push_back(renderer.readVisibility(i));
        images.techniques.push_back(renderer.techniqueName(i));
    }
    return images;
}

// "--reference-set samples=64", or with the reference's name as for --set:
// "--reference-set reference.samples=64".
config::ParamOverride parseReferenceSetting(const std::string& reference, const std::string& setting)
{
    const size_t eq = setting.find('=');
    std::string key = setting.substr(0, eq);
    if (const size_t dot = key.find('.'); dot != std::string::npos) {
        if (key.substr(0, dot) != reference) {
            throw Error(fmt::format("--reference-set '{}': '{}' is not the reference technique '{}' (--set sets the "
                                    "parameters of the techniques under test)",
                                    setting, key.substr(0, dot), reference));
        }
        key = key.substr(dot + 1);
    }
    if (eq == std::string::npos || key.empty()) {
        throw Error(fmt::format("--reference-set '{}': expected parameter=value, e.g. --reference-set samples=64", setting));
    }
    config::ParamOverride o = config::parseParamOverride(fmt::format("{}.{}{}", reference, key, setting.substr(eq)));
    o.where = fmt::format("--reference-set {}", key);
    return o;
}

// The reference technique with the --reference-set values, checked against the plugin's
// parameters before anything renders. Required: a reference that cannot run must stop
// the comparison, never compare against an unshadowed light.
config::ShadowSettings referenceShadow(const CompareFlags& flags, plugin::PluginRegistry& plugins, json& resolved)
{
    config::ShadowSettings shadow;
    shadow.technique = flags.reference;
    shadow.required = true;
    for (const std::string& setting : flags.referenceSettings) {
        config::ParamOverride o = parseReferenceSetting(flags.reference, setting);
        shadow.setParam(std::move(o.param), std::move(o.value), std::move(o.where));
    }
    const plugin::LoadedPlugin* loaded = nullptr;
    try {
        loaded = &plugins.load(flags.reference);
    } catch (const plugin::PluginError& e) {
        throw Error(fmt::format("--reference {}: {}", flags.reference, e.what()));
    }
    std::vector<std::string> errors;
    resolved = plugin::resolveParams(*loaded, shadow, &errors).toJson();
    if (!errors.empty()) throw Error(fmt::format("{}", fmt::join(errors, "\n")));
    return shadow;
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

    std::vector<fs::path> all() const
    {
        std::vector<fs::path> files;
        for (const Light& l : lights) files.insert(files.end(), {l.test, l.reference, l.diff});
        files.insert(files.end(), {colorTest, colorReference, metrics});
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
    files.metrics = dir / "metrics.json";
    return files;
}

// Fails before rendering when the folder cannot be made or a file in it not written. A
// folder that exists keeps every file that is not one of ours.
void checkOutputFolder(const fs::path& dir, const OutputFiles& files)
{
    std::error_code ec;
    if (!fs::exists(dir, ec)) {
        const fs::path parent = dir.has_parent_path() ? dir.parent_path() : fs::path(".");
        if (!fs::is_directory(parent, ec)) {
            throw Error(fmt::format("-o {}: cannot create the folder: '{}' does not exist", dir.string(), parent.string()));
        }
        io::checkWritable(dir);  // the parent is writable
        return;
    }
    if (!fs::is_directory(dir, ec)) throw Error(fmt::format("-o {}: exists and is not a folder", dir.string()));
    for (const fs::path& file : files.all()) io::checkWritable(file);
}

std::string percent(double value) { return fmt::format("{:.2f}%", value); }

void printStatsRow(const std::string& label, const metrics::ErrorStats& s)
{
    const std::string where = s.pixels > 0 ? fmt::format("({}, {})", s.maxX, s.maxY) : "-";
    fmt::print("  {:<9} {:>9} {:>9.5f} {:>9.5f} {:>9.5f} {:>12} {:>8} {:>8}\n", label, s.pixels, s.rmse, s.mae,
               s.maxAbsError, where, percent(s.percentAbove(0)), percent(s.percentAbove(1)));
}

void printStatsHeader()
{
    fmt::print("  {:<9} {:>9} {:>9} {:>9} {:>9} {:>12} {:>8} {:>8}\n", "region", "pixels", "RMSE", "MAE", "max", "max at",
               fmt::format(">{}", metrics::kErrorThresholds[0]), fmt::format(">{}", metrics::kErrorThresholds[1]));
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
    fmt::print("\ncolour (sRGB values in [0, 1], averaged over R, G, B):\n");
    printStatsHeader();
    printStatsRow("all", color.all);
    fmt::print("  SSIM (luma) {:.5f}\n", color.ssimLuma);
}

void writeJson(const fs::path& path, const json& doc)
{
    io::StagedFile file(path);
    std::ofstream out = file.openTemp();
    out << doc.dump(2) << '\n';
    out.close();
    if (!out) throw Error(fmt::format("{}: could not write the metrics", path.string()));
    file.commit();
}

void writeOutputs(const fs::path& dir, const OutputFiles& files, const FrameImages& test, const FrameImages& reference,
                  const metrics::PixelMask& mask, float diffScale, const json& doc)
{
    std::error_code ec;
    if (!fs::is_directory(dir, ec) && !fs::create_directory(dir, ec) && ec) {
        throw Error(fmt::format("-o {}: cannot create the folder: {}", dir.string(), ec.message()));
    }
    const uint32_t w = test.width, h = test.height;
    for (size_t i = 0; i < files.lights.size(); ++i) {
        const metrics::FloatImageView v{w, h, test.visibility[i]}, vRef{w, h, reference.visibility[i]};
        io::writePng(files.lights[i].test, w, h, metrics::visibilityGreyscale(v));
        io::writePng(files.lights[i].reference, w, h, metrics::visibilityGreyscale(vRef));
        io::writePng(files.lights[i].diff, w, h, metrics::differenceImage(v, vRef, &mask, diffScale));
    }
    io::writePng(files.colorTest, w, h, test.color);
    io::writePng(files.colorReference, w, h, reference.color);
    // Last: a metrics.json newer than the images says the set is complete.
    writeJson(files.metrics, doc);
}

} // namespace

int runCompare(const CompareFlags& flags, const gpu::ContextOptions& device)
{
    if (!(flags.diffScale > 0.0f && flags.diffScale <= 1.0f)) {
        throw Error(fmt::format("--diff-scale must be in (0, 1], got {}", flags.diffScale));
    }
    config::RenderConfig config = config::loadConfig(flags.config);
    const std::vector<config::ParamOverride> overrides = config::parseParamOverrides(flags.settings);
    if (flags.width) config.width = *flags.width;
    if (flags.height) config.height = *flags.height;

    plugin::PluginRegistry plugins;
    json referenceParams;
    const config::ShadowSettings reference = referenceShadow(flags, plugins, referenceParams);

    scene::Scene scene = config::buildScene(config);
    config::applyParamOverrides(config, overrides);  // after buildScene: "lights": "scene"
    if (!config.animation.empty()) {
        // An animated config is compared at its first frame, as `render` shows it.
        config::applyAnimation(config.animation, 0.0f, config, scene);
        scene.updateTransforms();
    }
    config::RenderConfig referenceConfig = config;
    for (config::LightConfig& light : referenceConfig.lights) light.shadow = reference;

    // "out/" names the folder "out".
    fs::path dir = fs::path(flags.output).lexically_normal();
    if (!dir.empty() && dir.filename().empty()) dir = dir.parent_path();
    const OutputFiles files = outputFiles(dir, config);
    if (!flags.output.empty()) checkOutputFolder(dir, files);

    gpu::Context context(device);
    spdlog::info("device: {} ({})", context.deviceInfo().name, context.deviceInfo().type);
    std::vector<std::string> warnings;
    const FrameImages test = renderOnce(context, scene, config, plugins, "test", warnings);
    const FrameImages ref = renderOnce(context, scene, referenceConfig, plugins, "reference", warnings);

    // Both renders drew the same scene from the same camera: one G-buffer's coverage.
    const metrics::PixelMask mask = metrics::geometryMask(ref.width, ref.height, ref.positions);
    const uint32_t w = test.width, h = test.height;
    std::vector<metrics::VisibilityComparison> comparisons;
    json doc = {{"config", flags.config},
                {"width", w},
                {"height", h},
                {"reference", {{"technique", flags.reference}, {"params", referenceParams}}},
                {"lights", json::array()}};
    for (size_t i = 0; i < config.lights.size(); ++i) {
        comparisons.push_back(metrics::compareVisibility({w, h, test.visibility[i]}, {w, h, ref.visibility[i]}, &mask));
        const metrics::VisibilityComparison& c = comparisons.back();
        const std::string& technique = test.techniques[i];
        json light = {{"index", i},
                      {"name", config.lights[i].name},
                      {"technique", technique.empty() ? "unshadowed" : technique},
                      {"params", technique.empty() ? json(nullptr)
                                                   : plugin::resolveParams(plugins.load(technique), config.lights[i].shadow).toJson()},
                      {"visibility", metrics::toJson(c)}};
        if (!flags.output.empty()) {
            light["files"] = {{"test", files.lights[i].test.filename().string()},
                              {"reference", files.lights[i].reference.filename().string()},
                              {"diff", files.lights[i].diff.filename().string()}};
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
    }
    doc["diff_scale"] = flags.diffScale;
    doc["warnings"] = warnings;

    // Files first: figures on stdout mean that the files, if asked for, are there too.
    if (!flags.output.empty()) {
        writeOutputs(dir, files, test, ref, mask, float(flags.diffScale), doc);
        spdlog::info("wrote {} files into {}", files.all().size(), dir.string());
    }
    if (flags.json) {
        fmt::print("{}\n", doc.dump(2));
    } else {
        printTable(doc, comparisons, color);
    }

    if (context.validationEnabled() && context.validationMessageCount() > 0) {
        spdlog::error("the Vulkan validation layer reported {} message(s)", context.validationMessageCount());
        return 3;
    }
    return 0;
}

} // namespace penumbra::app
