#pragma once
// Size checks shared by every comparison: each names the operation, the image and both
// sizes, so that a caller that mixed up two renders sees which.
#include "penumbra/metrics/Images.h"

#include <string_view>

namespace penumbra::metrics {

// An image as the checks see it: its name in messages, size, and how many values it holds.
struct ImageShape {
    std::string_view name;  // "test image"
    uint32_t width = 0;
    uint32_t height = 0;
    size_t values = 0;
};

// Throws Error when the image is empty or its value count is not width * height *
// channels ("visibility comparison: test image: 14399 values for 160x90 pixels of 1
// channel(s), expected 14400").
void checkPixelCount(std::string_view operation, const ImageShape& image, size_t channels);

// Both images checked, their sizes equal ("visibility comparison: test image is 160x90,
// reference image is 80x45"), and the mask, when not null, of that size too.
void checkComparable(std::string_view operation, const ImageShape& a, const ImageShape& b, size_t channels,
                     const PixelMask* mask);

} // namespace penumbra::metrics
