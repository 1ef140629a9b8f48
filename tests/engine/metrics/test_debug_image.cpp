// metrics::debugImageRgba (issue 21, debug views): any graph image mapped to RGBA8 from a
// range, linearly, logarithmically or through the false-colour ramp; channels shown as
// grey, red-green or RGB; non-finite values magenta; guarded against empty and
// zero-width ranges.
#include "penumbra/core/Error.h"
#include "penumbra/metrics/DebugImage.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

using namespace penumbra;
using metrics::DebugImageValues;
using metrics::DebugMapping;

namespace {

DebugImageValues ramp(uint32_t width, float from, float to)
{
    DebugImageValues image{width, 1, 1, {}};
    for (uint32_t x = 0; x < width; ++x) image.values.push_back(from + (to - from) * float(x) / float(width - 1));
    return image;
}

} // namespace

TEST(DebugImage, LinearMapsTheRangeToBlackThroughWhiteAndClampsOutside)
{
    const DebugImageValues image = ramp(5, -1.0f, 3.0f);  // -1, 0, 1, 2, 3
    const std::vector<uint8_t> rgba = metrics::debugImageRgba(image, DebugMapping::Linear, {0.0, 2.0});
    const uint8_t expected[5] = {0, 0, 128, 255, 255};
    for (size_t x = 0; x < 5; ++x) {
        EXPECT_EQ(rgba[4 * x], expected[x]) << x;
        EXPECT_EQ(rgba[4 * x + 1], expected[x]);
        EXPECT_EQ(rgba[4 * x + 2], expected[x]);
        EXPECT_EQ(rgba[4 * x + 3], 255);
    }
    const metrics::DebugRange found = metrics::finiteRange(image, DebugMapping::Linear);
    EXPECT_EQ(found.min, -1.0);
    EXPECT_EQ(found.max, 3.0);
}

TEST(DebugImage, LogSpreadsDecadesEvenlyAndNeedsNoPositiveMinimum)
{
    DebugImageValues image{4, 1, 1, {1e-3f, 1e-2f, 1e-1f, 1.0f}};
    std::vector<uint8_t> rgba = metrics::debugImageRgba(image, DebugMapping::Log, {1e-3, 1.0});
    EXPECT_EQ(rgba[0], 0);
    EXPECT_EQ(rgba[4], 85);
    EXPECT_EQ(rgba[8], 170);
    EXPECT_EQ(rgba[12], 255);
    // A range from 0 (a depth map's background): six decades below the top, no NaN.
    image.values = {0.0f, 1e-7f, 1e-3f, 1.0f};
    rgba = metrics::debugImageRgba(image, DebugMapping::Log, {0.0, 1.0});
    EXPECT_EQ(rgba[0], 0);
    EXPECT_EQ(rgba[4], 0);
    EXPECT_EQ(rgba[8], 128);
    EXPECT_EQ(rgba[12], 255);
}

TEST(DebugImage, FalseColorRunsFromDarkBlueToDarkRedThroughGreen)
{
    const std::vector<uint8_t> rgba = metrics::debugImageRgba(ramp(7, 0.0f, 1.0f), DebugMapping::FalseColor, {0.0, 1.0});
    EXPECT_GT(rgba[2], rgba[0]) << "the low end is blue";
    EXPECT_GT(rgba[4 * 3 + 1], rgba[4 * 3 + 0]) << "the middle is green";
    EXPECT_GT(rgba[4 * 3 + 1], rgba[4 * 3 + 2]);
    EXPECT_GT(rgba[4 * 6 + 0], rgba[4 * 6 + 2]) << "the high end is red";
    EXPECT_LT(rgba[4 * 6 + 0], 200) << "and dark";
}

TEST(DebugImage, ChannelsShowAsGreyRedGreenOrRgb)
{
    const DebugImageValues two{1, 1, 2, {1.0f, 0.5f}};
    std::vector<uint8_t> rgba = metrics::debugImageRgba(two, DebugMapping::Linear, {0.0, 1.0});
    EXPECT_EQ((std::vector<uint8_t>(rgba.begin(), rgba.end())), (std::vector<uint8_t>{255, 128, 0, 255}));
    const DebugImageValues four{1, 1, 4, {0.0f, 1.0f, 0.5f, 0.25f}};
    rgba = metrics::debugImageRgba(four, DebugMapping::Linear, {0.0, 1.0});
    EXPECT_EQ(rgba, (std::vector<uint8_t>{0, 255, 128, 255})) << "alpha is not shown";
}

TEST(DebugImage, NonFiniteValuesAreMagentaAndLeftOutOfTheRange)
{
    const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
    const DebugImageValues image{4, 1, 1, {nan, 2.0f, inf, 4.0f}};
    const metrics::DebugRange found = metrics::finiteRange(image, DebugMapping::Linear);
    EXPECT_EQ(found.min, 2.0);
    EXPECT_EQ(found.max, 4.0);
    EXPECT_EQ(found.nonFinite, 2u);
    const std::vector<uint8_t> rgba = metrics::debugImageRgba(image, DebugMapping::Linear, found);
    EXPECT_EQ((std::vector<uint8_t>(rgba.begin(), rgba.begin() + 3)), (std::vector<uint8_t>{255, 0, 255}));
    EXPECT_EQ((std::vector<uint8_t>(rgba.begin() + 8, rgba.begin() + 11)), (std::vector<uint8_t>{255, 0, 255}));
    EXPECT_EQ(rgba[4], 0);
    EXPECT_EQ(rgba[12], 255);
}

TEST(DebugImage, ConstantAndEmptyImagesNeedNoDivision)
{
    // A constant image (a cleared map): a range of zero width maps it to black.
    const DebugImageValues flat{3, 1, 1, {5.0f, 5.0f, 5.0f}};
    const metrics::DebugRange range = metrics::finiteRange(flat, DebugMapping::Log);
    for (DebugMapping m : {DebugMapping::Linear, DebugMapping::Log, DebugMapping::FalseColor}) {
        const std::vector<uint8_t> rgba = metrics::debugImageRgba(flat, m, range);
        EXPECT_EQ(rgba[0], rgba[4]) << metrics::debugMappingName(m);
    }
    // No finite value at all: the range is [0, 1].
    const DebugImageValues none{1, 1, 1, {std::numeric_limits<float>::quiet_NaN()}};
    const metrics::DebugRange empty = metrics::finiteRange(none, DebugMapping::Linear);
    EXPECT_EQ(empty.min, 0.0);
    EXPECT_EQ(empty.max, 1.0);
    // Bad input is an error, not a crash.
    EXPECT_THROW(metrics::debugImageRgba({2, 2, 1, {1.0f}}, DebugMapping::Linear, {0.0, 1.0}), Error);
    EXPECT_THROW(metrics::debugImageRgba(flat, DebugMapping::Linear, {1.0, 0.0}), Error);
    EXPECT_THROW(metrics::debugImageRgba(flat, DebugMapping::Linear, {0.0, std::nan("")}), Error);
    EXPECT_THROW(metrics::parseDebugMapping("sqrt"), ConfigError);
    EXPECT_EQ(metrics::parseDebugMapping("false-color"), DebugMapping::FalseColor);
}
