#pragma once
// `penumbra bench cfg.json`: runs the config's sweep (techniques × parameters × scenes ×
// lights) and measures every variant: per-pass GPU and CPU medians over N frames after
// K warm-up frames, transient memory per technique, and each light's visibility against
// the reference technique (rendered once per distinct scene, camera, light and image
// size, and reused for every technique variant that shares them). Writes results.csv,
// results.json and pareto.svg into -o DIR, and a Markdown summary with --summary.
// Exit codes as `render`: 0 done, 3 when the validation layer reported anything, 128 +
// the signal when interrupted (130 SIGINT, 143 SIGTERM; nothing is written then); bad
// input fails before anything renders (exit 1).
#include "CommandLine.h"

#include <string>
#include <vector>

namespace penumbra::app {

// `commandLine`: the whole command (argv), for the reports.
Command addBenchCommand(CLI::App& app, std::vector<std::string> commandLine);

} // namespace penumbra::app
