#pragma once
// Any image of a frame's graph shown as RGBA8 for a person to look at (a shadow map, a
// moment map, a summed-area table, a receiver mask): its values mapped from a range to
// grey or false colour. `penumbra render --debug-image NAME` writes one; the viewer shows
// them (issue 21).
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra::metrics {

enum class DebugMapping {
    Linear,      // (v - min) / (max - min)
    Log,         // log(v) between log(min) and log(max); min is raised to max * 1e-6 when <= 0
    FalseColor,  // linear, through a blue-green-yellow-red ramp (channel 0 only)
};
// "linear", "log", "false-color"; parse throws ConfigError listing them.
const char* debugMappingName(DebugMapping mapping);
DebugMapping parseDebugMapping(std::string_view name);

struct DebugImageValues {
    uint32_t width = 0, height = 0, channels = 1;  // values: width * height * channels, rows top first
    std::vector<float> values;
};

struct DebugRange {
    double min = 0.0, max = 1.0;
    uint64_t nonFinite = 0;  // values left out of an automatic range (NaN, ±inf)
};

// The range of the finite values of the channels the mapping shows (channel 0 for
// false colour, else up to three); {0, 1} when there is none.
DebugRange finiteRange(const DebugImageValues& image, DebugMapping mapping);

// RGBA8 rows, top first. One channel: grey (or false colour); two: red and green; three
// or four: RGB (alpha ignored). A value outside the range is clamped to it; a non-finite
// one is magenta (255, 0, 255). A range of zero width maps everything to its low end.
// Throws Error when the values do not fill width x height x channels, or the range is not
// finite with min <= max.
std::vector<uint8_t> debugImageRgba(const DebugImageValues& image, DebugMapping mapping, DebugRange range);

} // namespace penumbra::metrics
