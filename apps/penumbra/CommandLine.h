#pragma once
// What the `penumbra` commands share on the command line: the shape of a command (its
// flags and what it runs, declared by one addXCommand per file), and the flags that
// several commands take, declared once here: the device (--device, --device-type,
// --validation), technique parameters (--set), the output size (--width, --height) and
// the reference technique (--reference, --reference-set), the folders a glTF scene may
// read (--allow-root).
#include "penumbra/config/Run.h"
#include "penumbra/gpu/Context.h"
#include "penumbra/plugin/PluginRegistry.h"

#include <CLI/CLI.hpp>

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace penumbra::app {

// One subcommand: addXCommand(app) declares it on the CLI11 app with its flags (bound to
// storage that `run` owns) and returns it; main() runs the one the command line named.
struct Command {
    CLI::App* cli = nullptr;
    // The exit code; bad input throws penumbra::Error, which main() prints (exit 1).
    std::function<int()> run;
};

struct DeviceFlags {
    std::string name;
    std::string type;
    bool validation = false;
};
void addDeviceFlags(CLI::App& cmd, DeviceFlags& flags);
// The flags over the environment (PENUMBRA_DEVICE, PENUMBRA_VALIDATION).
gpu::ContextOptions contextOptions(const DeviceFlags& flags);
// What a command that renders exits with when done: 3 (logged) when the validation layer
// reported anything, else 0.
int validationExitCode(const gpu::Context& context);

// What a command changes in the config it runs: --set technique.param=value, and for
// the commands that render, --width and --height.
struct RunFlags {
    std::vector<std::string> settings;
    std::vector<std::string> allowedRoots;  // --allow-root
    std::optional<uint32_t> width;
    std::optional<uint32_t> height;
};
void addParamOverrideFlag(CLI::App& cmd, std::vector<std::string>& settings);
// --allow-root DIR (repeatable): a folder besides a glTF model's own whose files its URIs
// may name (scene::GltfLoadOptions::allowedRoots).
void addAllowRootFlag(CLI::App& cmd, std::vector<std::string>& roots);
// --width and --height; `overrides` says what they replace ("the config", "every variant").
void addSizeFlags(CLI::App& cmd, RunFlags& flags, const std::string& overrides = "the config");
// The flags as config::prepareRun takes them (the --set values parsed: ConfigError for a
// malformed one).
config::RunOptions runOptions(const RunFlags& flags);

// The config `file` as render, compare and graph draw it: as written. A sweep in it is
// for `bench` to run: a warning names it and says that `command` ignores it.
config::RenderConfig loadConfigIgnoringSweep(const std::string& file, const std::string& command);

// Before the device starts, what the run's lights' plugins would refuse: a parameter
// value (--set ones included) their metadata does not accept, a required technique that
// cannot be used (ConfigCheck, as `validate` finds them), thrown as one ConfigError.
// Another light whose plugin cannot be used is the renderer's to report: it warns and
// draws that light unshadowed.
void checkPluginsBeforeDevice(const config::RenderConfig& config, const config::RunOptions& options,
                              plugin::PluginRegistry& plugins);

// The technique that compare and bench measure against (ReferenceTechnique.h).
struct ReferenceFlags {
    std::string technique = "reference";
    std::vector<std::string> settings;  // --reference-set param=value (or NAME.param=value)
};
void addReferenceFlags(CLI::App& cmd, ReferenceFlags& flags);

} // namespace penumbra::app
