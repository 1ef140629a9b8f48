#include "penumbra/metrics/DifferenceImage.h"

#include "metrics/ImageChecks.h"
#include "penumbra/core/Error.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>

namespace penumbra::metrics {
namespace {

struct Rgb {
    uint8_t r, g, b;
};

// ColorBrewer RdBu (11 classes), each half from the centre outwards; the centre is pure
// white instead of RdBu's #f7f7f7 so that "equal" reads as exactly white.
constexpr std::array<Rgb, 6> kTooLit{{{255, 255, 255}, {253, 219, 199}, {244, 165, 130}, {214, 96, 77}, {178, 24, 43}, {103, 0, 31}}};
constexpr std::array<Rgb, 6> kTooDark{{{255, 255, 255}, {209, 229, 240}, {146, 197, 222}, {67, 147, 195}, {33, 102, 172}, {5, 48, 97}}};
constexpr Rgb kBackground{128, 128, 128};
constexpr Rgb kNotFiniteDifference{0, 255, 0};
constexpr Rgb kNotFiniteVisibility{255, 0, 255};

// `t` in [0, 1] along the stops, linear between neighbours in sRGB (as matplotlib
// interpolates a listed colour map).
Rgb interpolate(const std::array<Rgb, 6>& stops, double t)
{
    const double position = std::clamp(t, 0.0, 1.0) * double(stops.size() - 1);
    const size_t i = std::min(size_t(position), stops.size() - 2);
    const double f = position - double(i);
    const auto mix = [f](uint8_t a, uint8_t b) { return uint8_t(std::lround(double(a) + f * (double(b) - double(a)))); };
    return {mix(stops[i].r, stops[i + 1].r), mix(stops[i].g, stops[i + 1].g), mix(stops[i].b, stops[i + 1].b)};
}

void put(std::vector<uint8_t>& rgba, size_t pixel, Rgb c)
{
    rgba[4 * pixel + 0] = c.r;
    rgba[4 * pixel + 1] = c.g;
    rgba[4 * pixel + 2] = c.b;
    rgba[4 * pixel + 3] = 255;
}

} // namespace

std::vector<uint8_t> differenceImage(FloatImageView test, FloatImageView reference, const PixelMask* mask, float fullScale)
{
    checkComparable("difference image", {"test image", test.width, test.height, test.pixels.size()},
                    {"reference image", reference.width, reference.height, reference.pixels.size()}, 1, mask);
    if (!(fullScale > 0.0f && fullScale <= 1.0f)) {
        throw Error(fmt::format("difference image: the full scale must be in (0, 1], got {}", fullScale));
    }
    std::vector<uint8_t> rgba(test.pixels.size() * 4);
    for (size_t i = 0; i < test.pixels.size(); ++i) {
        const float t = test.pixels[i], r = reference.pixels[i];
        if (mask && !mask->covered[i]) {
            put(rgba, i, kBackground);
        } else if (!std::isfinite(t) || !std::isfinite(r)) {
            put(rgba, i, kNotFiniteDifference);
        } else {
            const double difference = double(t) - double(r);
            put(rgba, i, interpolate(difference > 0.0 ? kTooLit : kTooDark, std::abs(difference) / fullScale));
        }
    }
    return rgba;
}

std::vector<uint8_t> visibilityGreyscale(FloatImageView visibility)
{
    checkPixelCount("visibility image", {"image", visibility.width, visibility.height, visibility.pixels.size()}, 1);
    std::vector<uint8_t> rgba(visibility.pixels.size() * 4);
    for (size_t i = 0; i < visibility.pixels.size(); ++i) {
        const float v = visibility.pixels[i];
        if (!std::isfinite(v)) {
            put(rgba, i, kNotFiniteVisibility);
            continue;
        }
        const auto grey = uint8_t(std::lround(255.0 * std::clamp(double(v), 0.0, 1.0)));
        put(rgba, i, {grey, grey, grey});
    }
    return rgba;
}

} // namespace penumbra::metrics
