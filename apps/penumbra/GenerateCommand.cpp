#include "GenerateCommand.h"

#include "penumbra/core/Error.h"
#include "penumbra/core/ShortText.h"
#include "penumbra/scene/Generators.h"
#include "penumbra/scene/GltfWriter.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <optional>

namespace penumbra::app {
namespace {

struct GenerateFlags {
    std::string generator;
    std::string output;
    std::optional<uint32_t> seed;
    float scale = 1.0f;
    std::vector<std::string> settings;  // key=value
};

double millisecondsSince(std::chrono::steady_clock::time_point start)
{
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

int runGenerate(const GenerateFlags& flags)
{
    // Unknown generators and bad paths fail before any work.
    const std::vector<scene::GeneratorParam>& known = scene::generatorParameters(flags.generator);
    scene::checkGltfOutput(flags.output);
    if (!(std::isfinite(flags.scale) && flags.scale > 0.0f)) {
        throw Error(fmt::format("--scale must be a finite number > 0, got {}", flags.scale));
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
            throw Error(fmt::format("--set '{}': expected name=value, e.g. --set {}={}", core::shortText(setting),
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

// "60 world", "8": a parameter's default and its unit.
std::string defaultWithUnit(const scene::GeneratorParam& p)
{
    return p.unit.empty() ? fmt::format("{}", p.defaultValue) : fmt::format("{} {}", p.defaultValue, p.unit);
}

// The generators' parameter tables, for `penumbra generate --help`: each parameter's
// name, default and unit, range, and what it sets.
std::string generatorHelp()
{
    std::string text = "Generators and their parameters (name, default, range, what it sets; world: world units):\n";
    for (const std::string& name : scene::generatorNames()) {
        const std::vector<scene::GeneratorParam>& params = scene::generatorParameters(name);
        size_t nameWidth = 0, defaultWidth = 0, rangeWidth = 0;
        for (const scene::GeneratorParam& p : params) {
            nameWidth = std::max(nameWidth, p.name.size());
            defaultWidth = std::max(defaultWidth, defaultWithUnit(p).size());
            rangeWidth = std::max(rangeWidth, scene::describeRange(p).size());
        }
        text += fmt::format("  {}:\n", name);
        for (const scene::GeneratorParam& p : params) {
            text += fmt::format("    {:<{}}  {:<{}}  {:<{}}  {}\n", p.name, nameWidth, defaultWithUnit(p), defaultWidth,
                                scene::describeRange(p), rangeWidth, p.doc);
        }
    }
    return text;
}

} // namespace

Command addGenerateCommand(CLI::App& app)
{
    auto flags = std::make_shared<GenerateFlags>();
    CLI::App* cmd = app.add_subcommand("generate", "Write a procedural scene as glTF (.gltf + .bin, or .glb)");
    cmd->add_option("generator", flags->generator, fmt::format("One of: {}", fmt::join(scene::generatorNames(), ", ")))
        ->required();
    cmd->add_option("-o,--output", flags->output, "Output file: .gltf (writes a .bin beside it) or .glb")->required();
    cmd->add_option("--seed", flags->seed, "Seed of the generator's random choices");
    cmd->add_option("--scale", flags->scale, "Scale the whole scene about the origin (> 0)")->capture_default_str();
    cmd->add_option("--set", flags->settings, "Set a generator parameter: --set name=value (repeatable)")
        ->allow_extra_args(false);
    cmd->footer(generatorHelp());
    return {cmd, [flags] { return runGenerate(*flags); }};
}

} // namespace penumbra::app
