#pragma once
// How far a technique's image is from the reference's: a visibility image V_l against the
// reference technique's V_l (DESIGN.md: "metrics"), and the shaded colour images. Errors
// are per pixel of geometry (PixelMask); background pixels are never compared.
//
// Visibility: ΔV = V_test - V_ref. RMSE, MAE, max |ΔV| (and where), the share of pixels
// with |ΔV| above each of kErrorThresholds, over all compared pixels and split by the
// reference's region (umbra / penumbra / lit), plus the mean SSIM (metrics/Ssim.h).
// A value that is not finite (NaN, ±inf) in either image is counted and left out of every
// figure, never averaged in; a finite value outside [0, 1] is counted and compared as it
// is (its error is real).
//
// Colour: R, G, B of the sRGB-encoded bytes scaled to [0, 1] (alpha ignored). RMSE and MAE
// average over the three channels of every compared pixel; the maximum is the largest
// channel difference (which pixel and channel); a pixel is "above a threshold" when any
// channel differs by more; SSIM is computed on luma (colorLuma).
#include "penumbra/metrics/Images.h"

#include <nlohmann/json.hpp>

#include <array>
#include <cstdint>

namespace penumbra::metrics {

// The reference's regions: umbra where V_ref <= kUmbraMaxVisibility, lit where V_ref >=
// kLitMinVisibility, penumbra in between. The 1 % margins keep a reference's Monte Carlo
// noise (a few samples of 256 blocked) and filtering round-off out of the penumbra.
inline constexpr double kUmbraMaxVisibility = 0.01;
inline constexpr double kLitMinVisibility = 0.99;

enum class Region : uint8_t { Umbra, Penumbra, Lit };
inline constexpr size_t kRegionCount = 3;
Region classifyReference(float referenceVisibility);
const char* regionName(Region region);  // "umbra", "penumbra", "lit"

// A pixel is "wrong by more than t" when |ΔV| > t, for each t here: 0.05 and 0.2 for soft
// shadows, 0.5 for hard ones (a pixel on the wrong side of a shadow edge: the adaptive
// shadow map's "wrong pixels").
inline constexpr std::array<double, 3> kErrorThresholds{0.05, 0.2, 0.5};

// Error figures over one set of pixels. With pixels == 0 every figure is 0 (never NaN).
struct ErrorStats {
    uint64_t pixels = 0;        // pixels compared
    double rmse = 0.0;          // sqrt(mean ΔV²)
    double mae = 0.0;           // mean |ΔV|
    double maxAbsError = 0.0;   // max |ΔV|
    // Where the maximum is (pixel column x and row y from the top-left; the first such
    // pixel in row order) and the two values there; meaningful only when pixels > 0.
    uint32_t maxX = 0;
    uint32_t maxY = 0;
    double testAtMax = 0.0;
    double referenceAtMax = 0.0;
    std::array<uint64_t, kErrorThresholds.size()> pixelsAbove{};  // |ΔV| > kErrorThresholds[i]

    // 100 * pixelsAbove[i] / pixels; 0 when there are no pixels.
    double percentAbove(size_t threshold) const;
};

// Values in an image that are no visibility: counted, never silently averaged.
struct InvalidValues {
    uint64_t nonFinite = 0;   // NaN or ±inf: left out of every figure
    uint64_t outOfRange = 0;  // finite but outside [0, 1]: compared as they are
    uint64_t total() const { return nonFinite + outOfRange; }
};

struct VisibilityComparison {
    uint32_t width = 0;
    uint32_t height = 0;
    uint64_t geometryPixels = 0;  // pixels in the mask (every pixel without one)
    ErrorStats all;               // every compared pixel: geometry, both values finite
    std::array<ErrorStats, kRegionCount> regions;  // indexed by Region, by V_ref
    double ssim = 1.0;            // mean SSIM over the compared pixels (1 when there are none)
    InvalidValues test;           // in the test image's geometry pixels
    InvalidValues reference;      // in the reference image's geometry pixels

    const ErrorStats& region(Region r) const { return regions[size_t(r)]; }
};

// Compares a technique's visibility image with the reference's over the pixels of
// `mask` (all pixels when null). Throws Error naming both sizes when the images (or the
// mask) differ in size, or when a view holds the wrong number of values.
VisibilityComparison compareVisibility(FloatImageView test, FloatImageView reference, const PixelMask* mask = nullptr);

struct ColorComparison {
    uint32_t width = 0;
    uint32_t height = 0;
    uint64_t geometryPixels = 0;
    ErrorStats all;            // channel values in [0, 1]; see the file comment
    uint32_t maxChannel = 0;   // 0 R, 1 G, 2 B: the channel of all.maxAbsError
    double ssimLuma = 1.0;     // mean SSIM of colorLuma(test) against colorLuma(reference)
};

ColorComparison compareColor(Rgba8ImageView test, Rgba8ImageView reference, const PixelMask* mask = nullptr);

// Luma Y' = 0.2126 R' + 0.7152 G' + 0.0722 B' (ITU-R BT.709, the sRGB primaries) of the
// encoded values in [0, 1]: SSIM is defined on the displayed signal, not linear light.
std::vector<float> colorLuma(Rgba8ImageView image);

// JSON for `penumbra compare --json` and `penumbra bench`. Every number is finite.
//   ErrorStats: {"pixels", "rmse", "mae", "max_abs_error", "max_at": {"x", "y", "test",
//                "reference"} (null without pixels), "above": [{"threshold", "pixels", "percent"}]}
//   VisibilityComparison: {"width", "height", "geometry_pixels", "ssim", "all", "regions":
//                {"umbra", "penumbra", "lit"}, "region_bounds": {"umbra_max", "lit_min"},
//                "invalid": {"test": {"non_finite", "out_of_range"}, "reference": {...}}}
//   ColorComparison: {"width", "height", "geometry_pixels", "ssim_luma", "max_channel", "all"}
nlohmann::json toJson(const ErrorStats& stats);
nlohmann::json toJson(const VisibilityComparison& comparison);
nlohmann::json toJson(const ColorComparison& comparison);

} // namespace penumbra::metrics
