#include "penumbra/metrics/DebugImage.h"

#include "penumbra/core/Error.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace penumbra::metrics {
namespace {

// Channels the mapping shows.
uint32_t shownChannels(const DebugImageValues& image, DebugMapping mapping)
{
    return mapping == DebugMapping::FalseColor ? 1u : std::min(image.channels, 3u);
}

// The false-colour ramp: dark blue, blue, cyan, green, yellow, red, dark red at even
// steps (a rainbow ramp whose ends stay dark, as debuggers use for depth).
std::array<uint8_t, 3> ramp(double t)
{
    static constexpr std::array<std::array<double, 3>, 7> stops = {{{0.05, 0.05, 0.35},
                                                                    {0.10, 0.30, 0.95},
                                                                    {0.05, 0.80, 0.90},
                                                                    {0.15, 0.80, 0.20},
                                                                    {0.95, 0.90, 0.10},
                                                                    {0.90, 0.20, 0.05},
                                                                    {0.45, 0.02, 0.02}}};
    const double x = std::clamp(t, 0.0, 1.0) * double(stops.size() - 1);
    const size_t i = std::min(size_t(x), stops.size() - 2);
    const double f = x - double(i);
    std::array<uint8_t, 3> rgb{};
    for (size_t c = 0; c < 3; ++c) rgb[c] = uint8_t(std::lround(255.0 * (stops[i][c] * (1.0 - f) + stops[i + 1][c] * f)));
    return rgb;
}

} // namespace

const char* debugMappingName(DebugMapping mapping)
{
    switch (mapping) {
    case DebugMapping::Linear: return "linear";
    case DebugMapping::Log: return "log";
    case DebugMapping::FalseColor: return "false-color";
    }
    return "?";
}

DebugMapping parseDebugMapping(std::string_view name)
{
    for (DebugMapping m : {DebugMapping::Linear, DebugMapping::Log, DebugMapping::FalseColor}) {
        if (name == debugMappingName(m)) return m;
    }
    throw ConfigError(fmt::format("debug image mapping '{}': expected linear, log or false-color", name));
}

DebugRange finiteRange(const DebugImageValues& image, DebugMapping mapping)
{
    DebugRange range{std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(), 0};
    const uint32_t shown = shownChannels(image, mapping);
    const size_t pixels = size_t(image.width) * image.height;
    for (size_t p = 0; p < pixels && p * image.channels < image.values.size(); ++p) {
        for (uint32_t c = 0; c < shown; ++c) {
            const float v = image.values[p * image.channels + c];
            if (!std::isfinite(v)) {
                ++range.nonFinite;
                continue;
            }
            range.min = std::min(range.min, double(v));
            range.max = std::max(range.max, double(v));
        }
    }
    if (!(range.min <= range.max)) {
        range.min = 0.0;
        range.max = 1.0;
    }
    return range;
}

std::vector<uint8_t> debugImageRgba(const DebugImageValues& image, DebugMapping mapping, DebugRange range)
{
    const size_t pixels = size_t(image.width) * image.height;
    if (image.channels == 0 || image.values.size() != pixels * image.channels) {
        throw Error(fmt::format("debug image: {} values for {} x {} pixels of {} channel(s)", image.values.size(),
                                image.width, image.height, image.channels));
    }
    if (!(std::isfinite(range.min) && std::isfinite(range.max) && range.min <= range.max)) {
        throw Error(fmt::format("debug image: range [{}, {}] must be finite with min <= max", range.min, range.max));
    }
    // The mapping as t = (f(v) - f(lo)) * scale, scale 0 for a range of zero width.
    double lo = range.min, hi = range.max;
    const bool log = mapping == DebugMapping::Log;
    if (log) {
        // Logarithms need positive values: six decades below the top at most.
        const double top = std::max(hi, std::numeric_limits<double>::min());
        lo = std::log(std::max(lo, top * 1e-6));
        hi = std::log(top);
    }
    const double width = hi - lo;
    const double scale = width > 0.0 ? 1.0 / width : 0.0;
    const auto unit = [&](float v) {
        const double x = log ? std::log(std::max(double(v), std::exp(lo))) : double(v);
        return std::clamp((x - lo) * scale, 0.0, 1.0);
    };

    const uint32_t shown = shownChannels(image, mapping);
    std::vector<uint8_t> rgba(pixels * 4, 255);
    for (size_t p = 0; p < pixels; ++p) {
        const float* v = &image.values[p * image.channels];
        uint8_t* out = &rgba[p * 4];
        bool finite = true;
        for (uint32_t c = 0; c < shown; ++c) finite = finite && std::isfinite(v[c]);
        if (!finite) {
            out[0] = 255, out[1] = 0, out[2] = 255;
            continue;
        }
        if (mapping == DebugMapping::FalseColor) {
            const std::array<uint8_t, 3> rgb = ramp(unit(v[0]));
            out[0] = rgb[0], out[1] = rgb[1], out[2] = rgb[2];
        } else if (shown == 1) {
            out[0] = out[1] = out[2] = uint8_t(std::lround(255.0 * unit(v[0])));
        } else {
            for (uint32_t c = 0; c < 3; ++c) out[c] = c < shown ? uint8_t(std::lround(255.0 * unit(v[c]))) : 0;
        }
    }
    return rgba;
}

} // namespace penumbra::metrics
