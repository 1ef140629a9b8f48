#include "penumbra/metrics/ImageComparison.h"

#include "metrics/ImageChecks.h"
#include "penumbra/metrics/Ssim.h"

#include <cmath>

using nlohmann::json;

namespace penumbra::metrics {
namespace {

// Sums over a set of pixels, finished into ErrorStats. A pixel may carry several samples
// (the three colour channels); RMSE and MAE average over samples, the thresholds and the
// maximum go by each pixel's largest |Δ|. Sums are in double: a 1280x720 image adds 10^6
// terms, far inside double's 16 digits.
class ErrorAccumulator {
public:
    // Returns true when this pixel is the new maximum (the first in row order wins ties).
    bool add(uint32_t x, uint32_t y, double sumSquared, double sumAbs, uint32_t samples, double maxAbs, double test,
             double reference)
    {
        sumSquared_ += sumSquared;
        sumAbs_ += sumAbs;
        samples_ += samples;
        for (size_t t = 0; t < kErrorThresholds.size(); ++t) stats_.pixelsAbove[t] += maxAbs > kErrorThresholds[t];
        const bool newMax = stats_.pixels == 0 || maxAbs > stats_.maxAbsError;
        if (newMax) {
            stats_.maxAbsError = maxAbs;
            stats_.maxX = x;
            stats_.maxY = y;
            stats_.testAtMax = test;
            stats_.referenceAtMax = reference;
        }
        ++stats_.pixels;
        return newMax;
    }

    ErrorStats finish() const
    {
        ErrorStats stats = stats_;
        if (samples_ > 0) {
            stats.rmse = std::sqrt(sumSquared_ / double(samples_));
            stats.mae = sumAbs_ / double(samples_);
        }
        return stats;
    }

private:
    ErrorStats stats_;
    double sumSquared_ = 0.0;
    double sumAbs_ = 0.0;
    uint64_t samples_ = 0;
};

// Counts `v` in `invalid` when it is no visibility; true when it is finite.
bool checkVisibilityValue(float v, InvalidValues& invalid)
{
    if (!std::isfinite(v)) {
        ++invalid.nonFinite;
        return false;
    }
    if (v < 0.0f || v > 1.0f) ++invalid.outOfRange;
    return true;
}

// Calls f(x, y, index) for every pixel of `mask` (every pixel without one) in row order;
// returns how many there were.
template <typename PixelFunction>
uint64_t forEachComparedPixel(uint32_t width, uint32_t height, const PixelMask* mask, PixelFunction&& f)
{
    uint64_t count = 0;
    for (uint32_t y = 0; y < height; ++y) {
        for (uint32_t x = 0; x < width; ++x) {
            const size_t i = size_t(y) * width + x;
            if (mask && !mask->covered[i]) continue;
            ++count;
            f(x, y, i);
        }
    }
    return count;
}

template <typename View>
void checkTestAndReference(std::string_view operation, const View& test, const View& reference, size_t channels,
                           const PixelMask* mask)
{
    checkComparable(operation, {"test image", test.width, test.height, test.pixels.size()},
                    {"reference image", reference.width, reference.height, reference.pixels.size()}, channels, mask);
}

json invalidToJson(const InvalidValues& invalid)
{
    return {{"non_finite", invalid.nonFinite}, {"out_of_range", invalid.outOfRange}};
}

} // namespace

Region classifyReference(float referenceVisibility)
{
    if (referenceVisibility <= kUmbraMaxVisibility) return Region::Umbra;
    if (referenceVisibility >= kLitMinVisibility) return Region::Lit;
    return Region::Penumbra;
}

const char* regionName(Region region)
{
    switch (region) {
    case Region::Umbra: return "umbra";
    case Region::Penumbra: return "penumbra";
    case Region::Lit: return "lit";
    }
    return "?";
}

double ErrorStats::percentAbove(size_t threshold) const
{
    return pixels > 0 ? 100.0 * double(pixelsAbove.at(threshold)) / double(pixels) : 0.0;
}

VisibilityComparison compareVisibility(FloatImageView test, FloatImageView reference, const PixelMask* mask)
{
    checkTestAndReference("visibility comparison", test, reference, 1, mask);
    VisibilityComparison result;
    result.width = test.width;
    result.height = test.height;
    ErrorAccumulator all;
    std::array<ErrorAccumulator, kRegionCount> regions;
    result.geometryPixels = forEachComparedPixel(test.width, test.height, mask, [&](uint32_t x, uint32_t y, size_t i) {
        const float t = test.pixels[i], r = reference.pixels[i];
        const bool testFinite = checkVisibilityValue(t, result.test);
        const bool referenceFinite = checkVisibilityValue(r, result.reference);
        if (!testFinite || !referenceFinite) return;
        const double error = double(t) - double(r);
        const double absError = std::abs(error);
        all.add(x, y, error * error, absError, 1, absError, t, r);
        regions[size_t(classifyReference(r))].add(x, y, error * error, absError, 1, absError, t, r);
    });
    result.all = all.finish();
    for (size_t r = 0; r < kRegionCount; ++r) result.regions[r] = regions[r].finish();
    result.ssim = meanSsim(test, reference, mask);
    return result;
}

std::vector<float> colorLuma(Rgba8ImageView image)
{
    checkPixelCount("luma", {"image", image.width, image.height, image.pixels.size()}, 4);
    std::vector<float> luma(size_t(image.width) * image.height);
    for (size_t i = 0; i < luma.size(); ++i) {
        const uint8_t* p = &image.pixels[4 * i];
        luma[i] = float((0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]) / 255.0);
    }
    return luma;
}

ColorComparison compareColor(Rgba8ImageView test, Rgba8ImageView reference, const PixelMask* mask)
{
    checkTestAndReference("colour comparison", test, reference, 4, mask);
    ColorComparison result;
    result.width = test.width;
    result.height = test.height;
    ErrorAccumulator all;
    result.geometryPixels = forEachComparedPixel(test.width, test.height, mask, [&](uint32_t x, uint32_t y, size_t i) {
        double sumSquared = 0.0, sumAbs = 0.0, maxAbs = -1.0;
        uint32_t maxChannel = 0;
        for (uint32_t c = 0; c < 3; ++c) {
            const double error = (double(test.pixels[4 * i + c]) - double(reference.pixels[4 * i + c])) / 255.0;
            sumSquared += error * error;
            sumAbs += std::abs(error);
            if (std::abs(error) > maxAbs) {
                maxAbs = std::abs(error);
                maxChannel = c;
            }
        }
        if (all.add(x, y, sumSquared, sumAbs, 3, maxAbs, test.pixels[4 * i + maxChannel] / 255.0,
                    reference.pixels[4 * i + maxChannel] / 255.0)) {
            result.maxChannel = maxChannel;
        }
    });
    result.all = all.finish();
    const std::vector<float> testLuma = colorLuma(test), referenceLuma = colorLuma(reference);
    result.ssimLuma = meanSsim({test.width, test.height, testLuma}, {reference.width, reference.height, referenceLuma}, mask);
    return result;
}

json toJson(const ErrorStats& stats)
{
    json above = json::array();
    for (size_t t = 0; t < kErrorThresholds.size(); ++t) {
        above.push_back({{"threshold", kErrorThresholds[t]}, {"pixels", stats.pixelsAbove[t]}, {"percent", stats.percentAbove(t)}});
    }
    json maxAt = nullptr;
    if (stats.pixels > 0) {
        maxAt = {{"x", stats.maxX}, {"y", stats.maxY}, {"test", stats.testAtMax}, {"reference", stats.referenceAtMax}};
    }
    return {{"pixels", stats.pixels},
            {"rmse", stats.rmse},
            {"mae", stats.mae},
            {"max_abs_error", stats.maxAbsError},
            {"max_at", std::move(maxAt)},
            {"above", std::move(above)}};
}

json toJson(const VisibilityComparison& comparison)
{
    json regions = json::object();
    for (size_t r = 0; r < kRegionCount; ++r) regions[regionName(Region(r))] = toJson(comparison.regions[r]);
    return {{"width", comparison.width},
            {"height", comparison.height},
            {"geometry_pixels", comparison.geometryPixels},
            {"ssim", comparison.ssim},
            {"all", toJson(comparison.all)},
            {"regions", std::move(regions)},
            {"region_bounds", {{"umbra_max", kUmbraMaxVisibility}, {"lit_min", kLitMinVisibility}}},
            {"invalid", {{"test", invalidToJson(comparison.test)}, {"reference", invalidToJson(comparison.reference)}}}};
}

json toJson(const ColorComparison& comparison)
{
    static const char* const kChannels[] = {"R", "G", "B"};
    return {{"width", comparison.width},
            {"height", comparison.height},
            {"geometry_pixels", comparison.geometryPixels},
            {"ssim_luma", comparison.ssimLuma},
            {"max_channel", kChannels[comparison.maxChannel]},
            {"all", toJson(comparison.all)}};
}

} // namespace penumbra::metrics
