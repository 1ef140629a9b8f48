#pragma once
// `penumbra bench cfg.json`: runs the config's sweep (techniques × parameters × scenes ×
// lights) and measures every variant: per-pass GPU and CPU medians over N frames after
// K warm-up frames, transient memory per technique, and each light's visibility against
// the reference technique (rendered once per distinct scene, camera, light and image
// size, and reused for every technique variant that shares them). Writes results.csv,
// results.json and pareto.svg into -o DIR, and a Markdown summary with --summary.
#include "penumbra/gpu/Context.h"

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace penumbra::app {

struct BenchFlags {
    std::string config;
    std::string output;                          // -o DIR; empty: print the table only
    std::string summary;                         // --summary FILE.md; empty: none
    uint32_t frames = 10;                        // measured frames per variant
    uint32_t warmup = 1;                         // untimed frames before them
    std::string reference = "reference";         // --reference NAME
    std::vector<std::string> referenceSettings;  // --reference-set param=value
    std::vector<std::string> settings;           // --set technique.param=value, every variant
    std::optional<uint32_t> width;
    std::optional<uint32_t> height;
    std::vector<std::string> command;            // argv, for the reports
};

// Exit codes as `render`: 0 done, 3 when the validation layer reported anything, 128 +
// the signal when interrupted (130 SIGINT, 143 SIGTERM; nothing is written then); bad input throws
// penumbra::Error before anything renders (the caller prints it and exits 1).
int runBench(const BenchFlags& flags, const gpu::ContextOptions& device);

} // namespace penumbra::app
