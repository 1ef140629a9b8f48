#include "ValidateCommand.h"

#include "ConfigCheck.h"
#include "Phase.h"
#include "penumbra/config/Run.h"
#include "penumbra/config/Sweep.h"
#include "penumbra/core/Error.h"
#include "penumbra/core/ShortText.h"
#include "penumbra/plugin/PluginRegistry.h"
#include "penumbra/scene/GltfLoader.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <memory>

namespace penumbra::app {
namespace {

struct ValidateFlags {
    std::string file;
    bool weld = false;
    bool verbose = false;
    std::vector<std::string> settings;      // technique.param=value
    std::vector<std::string> allowedRoots;  // --allow-root
};

void printLight(const scene::GltfLight& gltfLight)
{
    const scene::Light& l = gltfLight.light;
    fmt::print("light '{}': {}", gltfLight.name, scene::lightTypeName(l.type));
    if (l.type != scene::LightType::Directional) {
        fmt::print(" at ({:.3g}, {:.3g}, {:.3g})", l.position.x, l.position.y, l.position.z);
    }
    if (l.type != scene::LightType::Point) {
        fmt::print(" pointing ({:.3g}, {:.3g}, {:.3g})", l.direction.x, l.direction.y, l.direction.z);
    }
    if (l.type == scene::LightType::Spot) fmt::print(", cone {:.3g}..{:.3g} deg", l.innerConeDeg, l.outerConeDeg);
    fmt::print(", intensity {:.4g}, color ({:.3g}, {:.3g}, {:.3g})\n", l.intensity, l.color.r, l.color.g, l.color.b);
}

std::string formatBounds(const scene::Aabb& b)
{
    if (b.empty()) return "empty";
    return fmt::format("({:.4g}, {:.4g}, {:.4g}) to ({:.4g}, {:.4g}, {:.4g})", b.min.x, b.min.y, b.min.z, b.max.x, b.max.y,
                       b.max.z);
}

std::string formatTransform(const config::PartTransform& t)
{
    std::string text = fmt::format("translation ({:.6g}, {:.6g}, {:.6g})", t.translation.x, t.translation.y, t.translation.z);
    if (t.rotationDeg) {
        text += fmt::format(", rotation_deg ({:.6g}, {:.6g}, {:.6g})", t.rotationDeg->x, t.rotationDeg->y, t.rotationDeg->z);
    } else {
        text += fmt::format(", rotation ({:.6g}, {:.6g}, {:.6g}, {:.6g})", t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w);
    }
    if (t.scale.x == t.scale.y && t.scale.y == t.scale.z) return text + fmt::format(", scale {:.6g}", t.scale.x);
    return text + fmt::format(", scale ({:.6g}, {:.6g}, {:.6g})", t.scale.x, t.scale.y, t.scale.z);
}

// The scene in total, then each part: what it draws and where it is after its transform.
// Triangles are those drawn (an instanced mesh counts per instance); materials those
// the meshes use.
void printScene(const config::SceneSource& source, const scene::Scene& scene)
{
    fmt::print("scene: {} part(s), {} meshes, {} instances, {} triangles, {} materials, {} textures, bounds {}\n",
               source.parts.size(), scene.meshes.size(), scene.instances.size(), scene.triangleCount(),
               scene.materialsUsed(), scene.textures.size(), formatBounds(scene.bounds()));
    const std::vector<config::PartSummary> summaries = config::summarizeParts(source, scene);
    for (size_t i = 0; i < source.parts.size(); ++i) {
        const config::ScenePart& part = source.parts[i];
        const std::string what = part.kind == config::ScenePart::Kind::Gltf ? config::displayPath(part.gltf)
                                                                            : "generator " + part.generator;
        fmt::print("  part {} '{}': {}, {}: {} instances, {} triangles, bounds {}\n", i, core::shortText(part.name), what,
                   formatTransform(part.transform), summaries[i].instances, summaries[i].triangles,
                   formatBounds(summaries[i].bounds));
    }
}

std::string describeRepair(const scene::RepairReport& r)
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
    scene::GltfLoadOptions options;
    options.repair.weld = flags.weld;
    options.repair.analyzeTopology = true;
    options.allowedRoots.assign(flags.allowedRoots.begin(), flags.allowedRoots.end());
    // The report lists every warning on stdout; logging them on stderr too would say
    // everything twice.
    if (!flags.verbose) spdlog::set_level(spdlog::level::err);
    scene::GltfLoadReport report;
    const scene::Scene scene = scene::loadGltf(flags.file, report, options);

    size_t meshTriangles = 0;
    for (const auto& mesh : scene.meshes) meshTriangles += mesh.indices.size() / 3;
    fmt::print("{}: {} meshes, {} triangles ({} drawn by {} instances), {} nodes, {} materials, {} textures, {} lights\n",
               flags.file, scene.meshes.size(), meshTriangles, scene.triangleCount(), scene.instances.size(),
               scene.graph.size(), scene.materialsUsed(), scene.textures.size(), report.lights.size());
    for (const auto& light : report.lights) printLight(light);
    for (size_t i = 0; i < scene.meshes.size(); ++i) {
        const scene::Mesh& mesh = scene.meshes[i];
        fmt::print("mesh {} '{}' ({}): {} triangles, {} vertices; {}\n", i, mesh.name, report.meshes[i].element,
                   mesh.indices.size() / 3, mesh.vertices.size(), describeRepair(report.meshes[i].repair));
    }
    for (const std::string& warning : report.warnings) fmt::print("warning: {}\n", warning);
    for (const std::string& note : report.notes) fmt::print("note: {}\n", note);
    fmt::print("ok: {} warnings\n", report.warnings.size());
    return 0;
}

// Checks everything a run would read: includes, every sweep variant, the scene (a glTF
// file is loaded, a generator run), the animation's node tracks, and each light's
// technique plugin with its parameters (--set overrides applied). Each distinct error is
// listed once, with the variants it was found in, and the last line counts them.
int runValidateConfig(const ValidateFlags& flags)
{
    const config::ConfigDocument document = inPhase("loading the config", [&] { return config::loadDocument(flags.file); });
    const config::SweepVariants variants(document);
    const bool swept = variants.swept();
    config::RunOptions options;
    options.overrides = config::parseParamOverrides(flags.settings);
    options.allowedRoots.assign(flags.allowedRoots.begin(), flags.allowedRoots.end());
    // A --set is for the variants whose lights use its technique, as `bench` applies it.
    options.overridesOfUsedTechniquesOnly = swept;
    const config::PreparedRun run =
        inPhase("loading the scene", [&] { return config::prepareRun(config::parseConfig(document), options); });
    const config::RenderConfig& base = run.config;
    const scene::Scene& scene = run.scene;
    printScene(base.scene, scene);
    for (const config::LightConfig& l : base.lights) {
        std::string params;
        for (const config::ShadowParam& p : l.shadow.params) {
            params += fmt::format(" {}={}", core::shortText(p.name), core::shortJson(p.value));
        }
        fmt::print("light '{}': {}, intensity {:.4g}, shadow {}{}{}\n", l.name, scene::lightTypeName(l.light.type),
                   l.light.intensity, l.shadow.technique, l.shadow.required == true ? " (required)" : "", params);
    }
    plugin::PluginRegistry plugins;
    ConfigCheck check(options, plugins, swept ? variants.size() : 0);
    check.checkConfig(base, true);
    fmt::print("output {}x{}, {} frame(s), culling {}, {} animation track(s) at {} fps\n", base.width, base.height,
               base.frames, config::cullingModeName(base.culling), base.animation.tracks.size(), base.animation.fps);
    if (swept) {
        fmt::print("sweep: {} variants\n", variants.size());
        for (size_t i = 0; i < variants.size(); ++i) {
            inPhase(fmt::format("checking sweep variant {} of {}", i + 1, variants.size()),
                    [&] { check.checkVariant(variants, i); });
            fmt::print("  variant {}: {}\n", i + 1, variants.label(i));
        }
        check.checkOverridesUsed();
    }
    for (const ConfigCheck::Finding& warning : check.warnings()) fmt::print("warning: {}\n", check.describe(warning));
    const size_t errors = check.errors().size();
    if (errors == 0) {
        fmt::print("{}: config ok\n", flags.file);
        return 0;
    }
    // The errors after everything else, however stdout and stderr are interleaved.
    std::fflush(stdout);
    for (const ConfigCheck::Finding& error : check.errors()) {
        fmt::print(stderr, "penumbra: error: {}\n", check.describe(error));
    }
    fmt::print(stderr, "{}: {} error{}\n", flags.file, errors, errors == 1 ? "" : "s");
    return 1;
}

int runValidate(const ValidateFlags& flags)
{
    std::string extension = std::filesystem::path(flags.file).extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    if ((extension == ".gltf" || extension == ".glb") && !flags.settings.empty()) {
        throw Error(fmt::format("{}: --set sets technique parameters of a config (.json), not of a glTF file",
                                core::shortText(flags.file)));
    }
    if (extension == ".gltf" || extension == ".glb") return runValidateGltf(flags);
    if (extension == ".json") return runValidateConfig(flags);
    throw Error(fmt::format("{}: unknown file type '{}': validate reads .gltf, .glb and .json", core::shortText(flags.file),
                            core::shortText(extension)));
}

} // namespace

Command addValidateCommand(CLI::App& app, const bool& verbose)
{
    auto flags = std::make_shared<ValidateFlags>();
    CLI::App* cmd = app.add_subcommand("validate", "Load a glTF file (.gltf/.glb) or a config (.json) and report what "
                                                   "was found and repaired; exit 1 with the error if it cannot be loaded");
    cmd->add_option("file", flags->file, "glTF file or scene config")->required();
    cmd->add_flag("--weld", flags->weld, "Also weld coincident vertices with equal attributes");
    addParamOverrideFlag(*cmd, flags->settings);
    addAllowRootFlag(*cmd, flags->allowedRoots);
    return {cmd, [flags, &verbose] {
                flags->verbose = verbose;
                return runValidate(*flags);
            }};
}

} // namespace penumbra::app
