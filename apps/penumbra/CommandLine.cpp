#include "CommandLine.h"

#include "ConfigCheck.h"
#include "penumbra/core/Error.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

namespace penumbra::app {

void addDeviceFlags(CLI::App& cmd, DeviceFlags& flags)
{
    cmd.add_option("--device", flags.name, "Use the Vulkan device whose name contains this text (env PENUMBRA_DEVICE)");
    cmd.add_option("--device-type", flags.type, "Use a device of this type")
        ->check(CLI::IsMember({"discrete", "integrated", "virtual", "cpu"}));
    cmd.add_flag("--validation", flags.validation,
                 "Enable the Vulkan validation layer; exit 3 if it reports anything (env PENUMBRA_VALIDATION=1)");
}

gpu::ContextOptions contextOptions(const DeviceFlags& flags)
{
    gpu::ContextOptions options;
    options.device.nameContains = flags.name;
    options.device.type = flags.type;
    options = gpu::contextOptionsFromEnvironment(options);
    if (flags.validation) options.validation = true;
    return options;
}

int validationExitCode(const gpu::Context& context)
{
    if (!context.validationEnabled() || context.validationMessageCount() == 0) return 0;
    spdlog::error("the Vulkan validation layer reported {} message(s)", context.validationMessageCount());
    return 3;
}

void addParamOverrideFlag(CLI::App& cmd, std::vector<std::string>& settings)
{
    cmd.add_option("--set", settings,
                   "Set a technique parameter for every light that uses the technique: --set hard.pcf_kernel=5 "
                   "(repeatable; the value is JSON, or plain text for enum choices; `penumbra plugins` lists them)")
        ->allow_extra_args(false);
}

void addAllowRootFlag(CLI::App& cmd, std::vector<std::string>& roots)
{
    cmd.add_option("--allow-root", roots,
                   "Let a glTF scene's buffer and image URIs name files under this folder too, besides the model's own "
                   "folder (repeatable; adds to the config's scene.allowed_roots)")
        ->check(CLI::ExistingDirectory)
        ->allow_extra_args(false);
}

void addSizeFlags(CLI::App& cmd, RunFlags& flags, const std::string& overrides)
{
    cmd.add_option("--width", flags.width, "Output width (overrides " + overrides + ")")->check(CLI::Range(1u, 16384u));
    cmd.add_option("--height", flags.height, "Output height (overrides " + overrides + ")")->check(CLI::Range(1u, 16384u));
}

config::RunOptions runOptions(const RunFlags& flags)
{
    config::RunOptions options;
    options.overrides = config::parseParamOverrides(flags.settings);
    options.allowedRoots.assign(flags.allowedRoots.begin(), flags.allowedRoots.end());
    options.width = flags.width;
    options.height = flags.height;
    return options;
}

config::RenderConfig loadConfigIgnoringSweep(const std::string& file, const std::string& command)
{
    const config::ConfigDocument document = config::loadDocument(file);
    if (document.json.contains("sweep")) {
        spdlog::warn("{}: /sweep: {} ignores the sweep and draws the config as written; `penumbra bench` runs its "
                     "variants (`penumbra validate` lists them)",
                     config::displayPath(document.fileFor("/sweep")), command);
    }
    return config::parseConfig(document);
}

void checkPluginsBeforeDevice(const config::RenderConfig& config, const config::RunOptions& options,
                              plugin::PluginRegistry& plugins)
{
    ConfigCheck check(options, plugins, 0);
    check.checkConfig(config, false);
    std::vector<std::string> errors;
    for (const ConfigCheck::Finding& error : check.errors()) errors.push_back(check.describe(error));
    if (!errors.empty()) throw ConfigError(fmt::format("{}", fmt::join(errors, "\n")));
}

void addReferenceFlags(CLI::App& cmd, ReferenceFlags& flags)
{
    cmd.add_option("--reference", flags.technique, "The reference technique plugin")->capture_default_str();
    cmd.add_option("--reference-set", flags.settings,
                   "Set a parameter of the reference technique: --reference-set samples=64 (repeatable)")
        ->allow_extra_args(false);
}

} // namespace penumbra::app
