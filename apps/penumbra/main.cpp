// penumbra: the command-line front end. Each command is declared in its own file with its
// flags (XCommand.cpp: addXCommand); this file only wires them: `render` a config to PNG,
// `generate` a procedural scene as glTF, `validate` a glTF file or a config, `plugins`
// lists the technique plugins, `graph` prints a frame's compiled render graph, `compare`
// measures techniques against the reference, `bench` measures a config's sweep, `devices`
// lists the Vulkan devices.
#include "BenchCommand.h"
#include "CommandLine.h"
#include "CompareCommand.h"
#include "DevicesCommand.h"
#include "GenerateCommand.h"
#include "GraphCommand.h"
#include "Phase.h"
#include "PluginsCommand.h"
#include "RenderCommand.h"
#include "ValidateCommand.h"
#include "penumbra/core/Error.h"
#include "penumbra/core/LeakCheck.h"
#include "penumbra/core/ShortText.h"

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <cstdio>
#include <exception>
#include <new>
#include <string>
#include <vector>

namespace {

int runCommandLine(int argc, char** argv)
{
    namespace app = penumbra::app;
    // Logs go to stderr so that stdout carries only results (timings) for scripts.
    spdlog::set_default_logger(spdlog::stderr_color_mt("penumbra"));
    spdlog::set_pattern("%^%l%$: %v");
    CLI::App cli{"penumbra: real-time shadows, every technique a plugin"};
    cli.require_subcommand(1);
    // CLI11 quotes an offending argument whole: a 100 KB argument shown shortened, as
    // every other message shows a value.
    cli.failure_message([](const CLI::App* app, const CLI::Error& e) {
        const std::string what = e.what();
        return penumbra::core::shortText(what) + CLI::FailureMessage::simple(app, e).substr(what.size());
    });
    bool verbose = false;
    cli.add_flag("-v,--verbose", verbose, "Log debug detail");

    // In the order `penumbra --help` lists them.
    const std::vector<app::Command> commands = {app::addRenderCommand(cli),
                                                app::addGenerateCommand(cli),
                                                app::addValidateCommand(cli, verbose),
                                                app::addPluginsCommand(cli),
                                                app::addDevicesCommand(cli),
                                                app::addGraphCommand(cli),
                                                app::addCompareCommand(cli),
                                                app::addBenchCommand(cli, {argv, argv + argc})};
    try {
        cli.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return cli.exit(e);
    }
    if (verbose) spdlog::set_level(spdlog::level::debug);

    std::string running;  // the command's name, for out-of-memory messages
    try {
        for (const app::Command& command : commands) {
            if (!command.cli->parsed()) continue;
            running = command.cli->get_name();
            return command.run();
        }
    } catch (const app::OutOfMemory& e) {
        fmt::print(stderr, "penumbra: error: {}: {}\n", running, e.what());
        return 1;
    } catch (const std::bad_alloc&) {
        // Outside every inPhase step: what was being allocated is not known.
        fmt::print(stderr, "penumbra: error: {}: out of memory\n", running);
        return 1;
    } catch (const penumbra::Error& e) {
        fmt::print(stderr, "penumbra: error: {}\n", e.what());
        return 1;
    } catch (const std::exception& e) {
        fmt::print(stderr, "penumbra: internal error: {}\n", e.what());
        return 2;
    }
    return 0;
}

} // namespace

int main(int argc, char** argv)
{
    const int status = runCommandLine(argc, argv);
    // After the command's objects are gone, before the libraries' destructors stop their
    // worker threads (Embree's TBB: the reference technique).
    penumbra::checkLeaksBeforeExit();
    return status;
}
