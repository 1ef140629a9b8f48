#include "penumbra/metrics/Images.h"

#include "metrics/ImageChecks.h"
#include "penumbra/core/Error.h"

#include <fmt/format.h>

#include <algorithm>

namespace penumbra::metrics {

uint64_t PixelMask::count() const
{
    return uint64_t(std::count_if(covered.begin(), covered.end(), [](uint8_t c) { return c != 0; }));
}

PixelMask geometryMask(uint32_t width, uint32_t height, std::span<const float> positions)
{
    checkPixelCount("geometry mask", {"G-buffer positions", width, height, positions.size()}, 4);
    PixelMask mask{width, height, std::vector<uint8_t>(size_t(width) * height)};
    for (size_t i = 0; i < mask.covered.size(); ++i) mask.covered[i] = positions[4 * i + 3] != 0.0f ? 1 : 0;
    return mask;
}

void checkPixelCount(std::string_view operation, const ImageShape& image, size_t channels)
{
    if (image.width == 0 || image.height == 0) {
        throw Error(fmt::format("{}: {} is empty ({}x{} pixels)", operation, image.name, image.width, image.height));
    }
    const size_t expected = size_t(image.width) * image.height * channels;
    if (image.values != expected) {
        throw Error(fmt::format("{}: {}: {} values for {}x{} pixels of {} channel(s), expected {}", operation, image.name,
                                image.values, image.width, image.height, channels, expected));
    }
}

void checkComparable(std::string_view operation, const ImageShape& a, const ImageShape& b, size_t channels,
                     const PixelMask* mask)
{
    const auto checkSameSize = [&](const ImageShape& other) {
        if (a.width != other.width || a.height != other.height) {
            throw Error(fmt::format("{}: {} is {}x{}, {} is {}x{}", operation, a.name, a.width, a.height, other.name,
                                    other.width, other.height));
        }
    };
    checkSameSize(b);
    checkPixelCount(operation, a, channels);
    checkPixelCount(operation, b, channels);
    if (mask) {
        const ImageShape maskShape{"mask", mask->width, mask->height, mask->covered.size()};
        checkSameSize(maskShape);
        checkPixelCount(operation, maskShape, 1);
    }
}

} // namespace penumbra::metrics
