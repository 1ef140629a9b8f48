// penumbra-viewer: the editor-style viewer (docs/viewer.md). Opens a scene config or a
// glTF file in a window; `--script FILE` / `--exec "cmd; cmd"` drive it without a person
// (the tests run it under xvfb-run).
#include "Script.h"
#include "Viewer.h"

#include "penumbra/core/Error.h"
#include "penumbra/core/LeakCheck.h"

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <cstdio>

namespace {

int runCommandLine(int argc, char** argv)
{
    namespace viewer = penumbra::viewer;
    spdlog::set_default_logger(spdlog::stderr_color_mt("penumbra-viewer"));
    spdlog::set_pattern("%^%l%$: %v");
    CLI::App cli{"penumbra-viewer: compare shadow techniques in a window"};
    std::string file, script, device, deviceType;
    std::vector<std::string> exec;
    bool noVsync = false, validation = false, verbose = false;
    uint32_t width = 0, height = 0;
    cli.add_option("file", file, "A scene config (.json) or a glTF file (.gltf, .glb)")->required();
    cli.add_option("--script", script, "Run the viewer commands in this file (docs/viewer.md), then stay open unless it quits");
    cli.add_option("--exec", exec, "Viewer commands separated by ';' (after --script's; repeatable)");
    cli.add_flag("--no-vsync", noVsync, "Present as fast as frames come (vsync is on by default)");
    cli.add_option("--window-width", width, "Window width in screen points (default: the frame's width plus the panel)")
        ->check(CLI::Range(64u, 16384u));
    cli.add_option("--window-height", height, "Window height in screen points (default: the frame's height)")
        ->check(CLI::Range(64u, 16384u));
    cli.add_option("--device", device, "Use the Vulkan device whose name contains this text (env PENUMBRA_DEVICE)");
    cli.add_option("--device-type", deviceType, "Use a device of this type")
        ->check(CLI::IsMember({"discrete", "integrated", "virtual", "cpu"}));
    cli.add_flag("--validation", validation,
                 "Enable the Vulkan validation layer; exit 3 if it reports anything (env PENUMBRA_VALIDATION=1)");
    cli.add_flag("-v,--verbose", verbose, "Log debug detail");
    cli.add_flag_callback(
        "--list-commands",
        [] {
            fmt::print("{}", viewer::Viewer::commands().list().markdown());
            throw CLI::Success();
        },
        "Print the script commands as docs/viewer.md's table (Markdown) and exit");
    try {
        cli.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return cli.exit(e);
    }
    if (verbose) spdlog::set_level(spdlog::level::debug);
    try {
        viewer::ViewerOptions options;
        options.file = file;
        if (!script.empty()) options.script = viewer::readScript(script);
        for (const std::string& text : exec) {
            for (viewer::ScriptCommand& c : viewer::parseScript(text, "--exec", true)) options.script.push_back(std::move(c));
        }
        options.vsync = !noVsync;
        options.windowWidth = width;
        options.windowHeight = height;
        options.context.device.nameContains = device;
        options.context.device.type = deviceType;
        options.context = penumbra::gpu::contextOptionsFromEnvironment(options.context);
        if (validation) options.context.validation = true;
        return viewer::runViewer(options);
    } catch (const penumbra::Error& e) {
        fmt::print(stderr, "penumbra-viewer: error: {}\n", e.what());
        return 1;
    }
}

} // namespace

int main(int argc, char** argv)
{
    const int status = runCommandLine(argc, argv);
    penumbra::checkLeaksBeforeExit();
    return status;
}
