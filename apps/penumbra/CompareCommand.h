#pragma once
// `penumbra compare cfg.json`: renders the config with each light's own technique, then
// again with every light's technique replaced by the reference technique, and measures
// each light's visibility image and the colour image against the reference's
// (metrics/ImageComparison.h); optionally writes the images and the figures to a folder.
#include "penumbra/gpu/Context.h"
#include "penumbra/metrics/DifferenceImage.h"

#include <optional>
#include <string>
#include <vector>

namespace penumbra::app {

struct CompareFlags {
    std::string config;
    std::string output;                          // -o DIR; empty: print the figures only
    std::string reference = "reference";         // --reference NAME: the technique plugin
    std::vector<std::string> referenceSettings;  // --reference-set param=value (or NAME.param=value)
    std::vector<std::string> settings;           // --set technique.param=value: the test render
    std::optional<uint32_t> width;
    std::optional<uint32_t> height;
    bool json = false;                           // print the JSON document instead of the table
    double diffScale = metrics::kDefaultDifferenceFullScale;  // --diff-scale: |ΔV| of full colour
};

// Exit codes as `render`: 0 done, 3 when the validation layer reported anything; bad
// input throws penumbra::Error (the caller prints it and exits 1).
int runCompare(const CompareFlags& flags, const gpu::ContextOptions& device);

} // namespace penumbra::app
