// The metrics module on hand-made images whose answers are known: error figures, the
// region split, SSIM (against a direct evaluation of Wang et al.'s definition), colour,
// the images to look at, the JSON form, and every guard (empty mask, constant images,
// non-finite values, size mismatches).
#include "ErrorText.h"
#include "penumbra/core/Error.h"
#include "penumbra/metrics/DifferenceImage.h"
#include "penumbra/metrics/ImageComparison.h"
#include "penumbra/metrics/Pareto.h"
#include "penumbra/metrics/Ssim.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <random>

using namespace penumbra;
using namespace penumbra::metrics;
using penumbra::test::errorOf;

namespace {

// An image that owns its pixels, viewed by the metrics.
struct Image {
    uint32_t width = 0;
    uint32_t height = 0;
    std::vector<float> pixels;

    Image(uint32_t w, uint32_t h, float value = 0.0f) : width(w), height(h), pixels(size_t(w) * h, value) {}
    float& at(uint32_t x, uint32_t y) { return pixels[size_t(y) * width + x]; }
    FloatImageView view() const { return {width, height, pixels}; }
};

Image randomImage(uint32_t w, uint32_t h, uint32_t seed, float lo = 0.0f, float hi = 1.0f)
{
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> value(lo, hi);
    Image image(w, h);
    for (float& v : image.pixels) v = value(rng);
    return image;
}

// A smooth image with structure (soft-edged disc), closer to a visibility image than noise.
Image softDisc(uint32_t w, uint32_t h)
{
    Image image(w, h);
    for (uint32_t y = 0; y < h; ++y)
        for (uint32_t x = 0; x < w; ++x) {
            const float d = std::hypot(float(x) - 0.5f * float(w), float(y) - 0.5f * float(h));
            image.at(x, y) = std::clamp((d - 0.25f * float(w)) / 6.0f, 0.0f, 1.0f);
        }
    return image;
}

PixelMask fullMask(uint32_t w, uint32_t h) { return {w, h, std::vector<uint8_t>(size_t(w) * h, 1)}; }

// SSIM as the paper defines it, evaluated directly: for every pixel, the 2D Gaussian
// window's weights over the compared pixels, renormalised; mean over compared pixels.
double directSsim(const Image& a, const Image& b, const PixelMask* mask)
{
    const double c1 = kSsimK1 * kSsimK1, c2 = kSsimK2 * kSsimK2;
    const int r = kSsimWindowRadius, w = int(a.width), h = int(a.height);
    const auto compared = [&](int x, int y) { return !mask || mask->covered[size_t(y) * a.width + size_t(x)]; };
    double sum = 0.0;
    int count = 0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            if (!compared(x, y)) continue;
            double weight = 0, ma = 0, mb = 0;
            for (int j = -r; j <= r; ++j)
                for (int i = -r; i <= r; ++i) {
                    if (x + i < 0 || x + i >= w || y + j < 0 || y + j >= h || !compared(x + i, y + j)) continue;
                    const double g = std::exp(-(i * i + j * j) / (2 * kSsimSigma * kSsimSigma));
                    weight += g;
                    ma += g * a.pixels[size_t((y + j) * w + x + i)];
                    mb += g * b.pixels[size_t((y + j) * w + x + i)];
                }
            ma /= weight;
            mb /= weight;
            double va = 0, vb = 0, cov = 0;
            for (int j = -r; j <= r; ++j)
                for (int i = -r; i <= r; ++i) {
                    if (x + i < 0 || x + i >= w || y + j < 0 || y + j >= h || !compared(x + i, y + j)) continue;
                    const double g = std::exp(-(i * i + j * j) / (2 * kSsimSigma * kSsimSigma)) / weight;
                    const double da = a.pixels[size_t((y + j) * w + x + i)] - ma;
                    const double db = b.pixels[size_t((y + j) * w + x + i)] - mb;
                    va += g * da * da;
                    vb += g * db * db;
                    cov += g * da * db;
                }
            sum += (2 * ma * mb + c1) * (2 * cov + c2) / ((ma * ma + mb * mb + c1) * (va + vb + c2));
            ++count;
        }
    return sum / count;
}

// nlohmann writes NaN and inf as null: every number must be finite and no figure null.
void expectAllFinite(const nlohmann::json& j)
{
    if (j.is_structured()) {
        for (const auto& item : j) expectAllFinite(item);
    } else if (j.is_number_float()) {
        EXPECT_TRUE(std::isfinite(j.get<double>()));
    }
}

} // namespace

TEST(Metrics, IdenticalImagesHaveNoErrorAndSsimOne)
{
    const Image v = randomImage(40, 30, 1);
    const VisibilityComparison c = compareVisibility(v.view(), v.view());
    EXPECT_EQ(c.geometryPixels, 1200u);
    EXPECT_EQ(c.all.pixels, 1200u);
    EXPECT_EQ(c.all.rmse, 0.0);
    EXPECT_EQ(c.all.mae, 0.0);
    EXPECT_EQ(c.all.maxAbsError, 0.0);
    EXPECT_EQ(c.all.pixelsAbove[0], 0u);
    EXPECT_EQ(c.all.pixelsAbove[1], 0u);
    EXPECT_NEAR(c.ssim, 1.0, 1e-12);
    EXPECT_EQ(c.test.total(), 0u);
    EXPECT_EQ(c.reference.total(), 0u);
}

TEST(Metrics, ConstantOffsetGivesRmseEqualToMaeEqualToTheOffset)
{
    const Image reference = randomImage(64, 48, 2, 0.0f, 0.8f);
    Image test = reference;
    for (float& v : test.pixels) v += 0.125f;
    const VisibilityComparison c = compareVisibility(test.view(), reference.view());
    // |ΔV| is 0.125 to within float rounding of V + 0.125 (half an ulp of 1: 6e-8).
    EXPECT_NEAR(c.all.rmse, 0.125, 1e-7);
    EXPECT_NEAR(c.all.mae, 0.125, 1e-7);
    EXPECT_NEAR(c.all.maxAbsError, 0.125, 1e-7);
    EXPECT_DOUBLE_EQ(c.all.percentAbove(0), 100.0);  // 0.125 > 0.05
    EXPECT_DOUBLE_EQ(c.all.percentAbove(1), 0.0);    // 0.125 <= 0.2
    EXPECT_LT(c.ssim, 1.0);
}

TEST(Metrics, KnownErrorsGiveKnownFigures)
{
    Image reference(4, 1), test(4, 1);
    reference.pixels = {0.5f, 0.5f, 0.5f, 0.5f};
    test.pixels = {0.625f, 0.25f, 0.5f, 0.6875f};  // ΔV = +0.125, -0.25, 0, +0.1875 (exact in float)
    const ErrorStats s = compareVisibility(test.view(), reference.view()).all;
    EXPECT_DOUBLE_EQ(s.rmse, std::sqrt((0.125 * 0.125 + 0.25 * 0.25 + 0.1875 * 0.1875) / 4.0));
    EXPECT_DOUBLE_EQ(s.mae, (0.125 + 0.25 + 0.1875) / 4.0);
    EXPECT_DOUBLE_EQ(s.maxAbsError, 0.25);
    EXPECT_EQ(s.maxX, 1u);
    EXPECT_EQ(s.maxY, 0u);
    EXPECT_DOUBLE_EQ(s.testAtMax, 0.25);
    EXPECT_DOUBLE_EQ(s.referenceAtMax, 0.5);
    EXPECT_EQ(s.pixelsAbove[0], 3u);
    EXPECT_EQ(s.pixelsAbove[1], 1u);
    EXPECT_DOUBLE_EQ(s.percentAbove(0), 75.0);
    EXPECT_DOUBLE_EQ(s.percentAbove(1), 25.0);
}

TEST(Metrics, RegionsSplitByTheReferencesVisibility)
{
    // 10 x 10: row 0-1 umbra (20 px), rows 2-4 penumbra (30 px), rows 5-9 lit (50 px), with
    // the bounds themselves on the umbra and lit side.
    Image reference(10, 10), test(10, 10);
    for (uint32_t y = 0; y < 10; ++y)
        for (uint32_t x = 0; x < 10; ++x) {
            float v = y < 2 ? 0.0f : y < 5 ? 0.5f : 1.0f;
            if (x == 0 && y == 0) v = float(kUmbraMaxVisibility);
            if (x == 0 && y == 9) v = float(kLitMinVisibility);
            if (x == 0 && y == 2) v = 0.0101f;
            if (x == 0 && y == 3) v = 0.9899f;
            reference.at(x, y) = v;
        }
    // Errors by region: umbra +0.25, penumbra -0.125, lit 0.
    for (uint32_t i = 0; i < 100; ++i) {
        const float r = reference.pixels[i];
        const Region region = classifyReference(r);
        test.pixels[i] = r + (region == Region::Umbra ? 0.25f : region == Region::Penumbra ? -0.125f : 0.0f);
    }
    const VisibilityComparison c = compareVisibility(test.view(), reference.view());
    EXPECT_EQ(c.region(Region::Umbra).pixels, 20u);
    EXPECT_EQ(c.region(Region::Penumbra).pixels, 30u);
    EXPECT_EQ(c.region(Region::Lit).pixels, 50u);
    EXPECT_NEAR(c.region(Region::Umbra).rmse, 0.25, 1e-7);
    EXPECT_NEAR(c.region(Region::Umbra).mae, 0.25, 1e-7);
    EXPECT_NEAR(c.region(Region::Penumbra).rmse, 0.125, 1e-7);
    EXPECT_EQ(c.region(Region::Lit).rmse, 0.0);
    EXPECT_EQ(c.region(Region::Lit).maxAbsError, 0.0);
    EXPECT_EQ(c.region(Region::Umbra).pixelsAbove[0], 20u);
    EXPECT_EQ(c.region(Region::Umbra).pixelsAbove[1], 20u);
    EXPECT_EQ(c.region(Region::Penumbra).pixelsAbove[0], 30u);
    EXPECT_EQ(c.region(Region::Penumbra).pixelsAbove[1], 0u);
    EXPECT_NEAR(c.all.rmse, std::sqrt((20 * 0.0625 + 30 * 0.015625) / 100.0), 1e-7);
    EXPECT_EQ(std::string(regionName(Region::Penumbra)), "penumbra");
}

TEST(Metrics, AnEmptyRegionReportsZeroPixelsAndNoNan)
{
    const Image reference(8, 8, 0.5f), test(8, 8, 0.75f);  // all penumbra
    const VisibilityComparison c = compareVisibility(test.view(), reference.view());
    for (Region r : {Region::Umbra, Region::Lit}) {
        const ErrorStats& s = c.region(r);
        EXPECT_EQ(s.pixels, 0u);
        EXPECT_EQ(s.rmse, 0.0);
        EXPECT_EQ(s.mae, 0.0);
        EXPECT_EQ(s.maxAbsError, 0.0);
        EXPECT_EQ(s.percentAbove(0), 0.0);
        EXPECT_TRUE(toJson(s)["max_at"].is_null());
    }
    EXPECT_EQ(c.region(Region::Penumbra).pixels, 64u);
    expectAllFinite(toJson(c));
}

TEST(Metrics, SsimMatchesADirectEvaluationOfTheDefinition)
{
    const Image a = softDisc(37, 29);
    Image b = a;
    std::mt19937 rng(3);
    std::normal_distribution<float> noise(0.0f, 0.05f);
    for (float& v : b.pixels) v = std::clamp(v + noise(rng), 0.0f, 1.0f);
    EXPECT_NEAR(meanSsim(a.view(), b.view()), directSsim(a, b, nullptr), 1e-10);
    // With a mask of irregular holes, too.
    PixelMask mask = fullMask(37, 29);
    for (size_t i = 0; i < mask.covered.size(); ++i) mask.covered[i] = (i * 7919) % 5 != 0;
    EXPECT_NEAR(meanSsim(a.view(), b.view(), &mask), directSsim(a, b, &mask), 1e-10);
}

TEST(Metrics, SsimOfANoisyImageIsBelowOneAndSymmetric)
{
    const Image clean = softDisc(64, 64);
    double previous = 1.0;
    for (float sigma : {0.02f, 0.1f, 0.3f}) {
        Image noisy = clean;
        std::mt19937 rng(4);
        std::normal_distribution<float> noise(0.0f, sigma);
        for (float& v : noisy.pixels) v = std::clamp(v + noise(rng), 0.0f, 1.0f);
        const double ab = meanSsim(clean.view(), noisy.view());
        EXPECT_LT(ab, previous) << "more noise, lower SSIM: sigma " << sigma;
        EXPECT_GT(ab, -1.0);
        EXPECT_EQ(ab, meanSsim(noisy.view(), clean.view()));
        previous = ab;
    }
}

TEST(Metrics, SsimOfConstantImagesIsTheLuminanceTerm)
{
    // σ = 0 in both: the structure term is C2 / C2 and SSIM = (2ab + C1) / (a² + b² + C1).
    const Image a(16, 16, 0.25f), b(16, 16, 0.75f);
    const double c1 = kSsimK1 * kSsimK1;
    EXPECT_NEAR(meanSsim(a.view(), b.view()), (2 * 0.25 * 0.75 + c1) / (0.25 * 0.25 + 0.75 * 0.75 + c1), 1e-12);
    // Both black: C1 keeps 0 / 0 away.
    const Image black(16, 16, 0.0f);
    EXPECT_DOUBLE_EQ(meanSsim(black.view(), black.view()), 1.0);
    EXPECT_NEAR(meanSsim(black.view(), a.view()), c1 / (0.25 * 0.25 + c1), 1e-12);
}

TEST(Metrics, BackgroundNeverEntersTheStatistics)
{
    // Left half equal, right half (background) wildly different: the masked figures see
    // only the left half, even in windows that straddle the edge.
    Image reference = softDisc(32, 16), test = reference;
    PixelMask mask = fullMask(32, 16);
    for (uint32_t y = 0; y < 16; ++y)
        for (uint32_t x = 16; x < 32; ++x) {
            test.at(x, y) = 1.0f - reference.at(x, y) + 7.0f;
            mask.covered[size_t(y) * 32 + x] = 0;
        }
    const VisibilityComparison c = compareVisibility(test.view(), reference.view(), &mask);
    EXPECT_EQ(c.geometryPixels, 256u);
    EXPECT_EQ(c.all.pixels, 256u);
    EXPECT_EQ(c.all.maxAbsError, 0.0);
    EXPECT_NEAR(c.ssim, 1.0, 1e-12);
    EXPECT_EQ(c.test.outOfRange, 0u) << "background values are not counted";
}

TEST(Metrics, EmptyMaskGivesZeroPixelsAndNoNan)
{
    const Image a = randomImage(8, 8, 5), b = randomImage(8, 8, 6);
    const PixelMask empty{8, 8, std::vector<uint8_t>(64, 0)};
    const VisibilityComparison c = compareVisibility(a.view(), b.view(), &empty);
    EXPECT_EQ(c.geometryPixels, 0u);
    EXPECT_EQ(c.all.pixels, 0u);
    EXPECT_EQ(c.all.rmse, 0.0);
    EXPECT_EQ(c.ssim, 1.0);
    expectAllFinite(toJson(c));
    EXPECT_TRUE(toJson(c)["all"]["max_at"].is_null());
}

TEST(Metrics, NonFiniteValuesAreCountedAndLeftOut)
{
    const Image reference = randomImage(12, 12, 7);
    Image test = reference;
    for (float& v : test.pixels) v = std::min(1.0f, v + 0.0625f);
    Image clean = test;
    test.at(3, 4) = std::numeric_limits<float>::quiet_NaN();
    test.at(5, 5) = std::numeric_limits<float>::infinity();
    test.at(6, 6) = -std::numeric_limits<float>::infinity();
    test.at(1, 1) = 1.5f;  // finite, out of range: compared as it is
    clean.at(1, 1) = 1.5f;
    const VisibilityComparison c = compareVisibility(test.view(), reference.view());
    EXPECT_EQ(c.test.nonFinite, 3u);
    EXPECT_EQ(c.test.outOfRange, 1u);
    EXPECT_EQ(c.reference.total(), 0u);
    EXPECT_EQ(c.geometryPixels, 144u);
    EXPECT_EQ(c.all.pixels, 141u);
    EXPECT_TRUE(std::isfinite(c.all.rmse));
    EXPECT_TRUE(std::isfinite(c.ssim));

    // The same figures as with those three pixels masked out.
    PixelMask mask = fullMask(12, 12);
    for (auto [x, y] : {std::pair{3, 4}, {5, 5}, {6, 6}}) mask.covered[size_t(y) * 12 + size_t(x)] = 0;
    const VisibilityComparison masked = compareVisibility(clean.view(), reference.view(), &mask);
    EXPECT_DOUBLE_EQ(c.all.rmse, masked.all.rmse);
    EXPECT_DOUBLE_EQ(c.all.mae, masked.all.mae);
    EXPECT_DOUBLE_EQ(c.all.maxAbsError, masked.all.maxAbsError);
    EXPECT_DOUBLE_EQ(c.ssim, masked.ssim);
    EXPECT_EQ(c.all.maxX, 1u) << "the out-of-range value is the largest error";

    // A non-finite reference value is counted on the reference's side.
    Image badReference = reference;
    badReference.at(0, 0) = std::numeric_limits<float>::quiet_NaN();
    const VisibilityComparison r = compareVisibility(clean.view(), badReference.view());
    EXPECT_EQ(r.reference.nonFinite, 1u);
    EXPECT_EQ(r.all.pixels, 143u);
    expectAllFinite(toJson(r));
}

TEST(Metrics, SizeMismatchIsAnErrorNamingBothSizes)
{
    const Image a(4, 3), b(3, 4);
    EXPECT_EQ(errorOf([&] { compareVisibility(a.view(), b.view()); }),
              "visibility comparison: test image is 4x3, reference image is 3x4");
    const PixelMask mask = fullMask(4, 4);
    EXPECT_EQ(errorOf([&] { compareVisibility(a.view(), a.view(), &mask); }),
              "visibility comparison: test image is 4x3, mask is 4x4");
    const std::vector<float> short_(11);
    EXPECT_EQ(errorOf([&] { compareVisibility({4, 3, short_}, a.view()); }),
              "visibility comparison: test image: 11 values for 4x3 pixels of 1 channel(s), expected 12");
    EXPECT_EQ(errorOf([&] { meanSsim(a.view(), b.view()); }), "SSIM: first image is 4x3, second image is 3x4");
    EXPECT_EQ(errorOf([&] { meanSsim(a.view(), a.view(), nullptr, 0.0); }),
              "SSIM: the dynamic range must be a finite number > 0, got 0");
    const Image empty(0, 0);
    EXPECT_EQ(errorOf([&] { compareVisibility(empty.view(), empty.view()); }),
              "visibility comparison: test image is empty (0x0 pixels)");
    const std::vector<uint8_t> rgba(4 * 12), rgbaOther(4 * 12);
    EXPECT_EQ(errorOf([&] { compareColor({4, 3, rgba}, {6, 2, rgbaOther}); }),
              "colour comparison: test image is 4x3, reference image is 6x2");
    EXPECT_EQ(errorOf([&] { geometryMask(4, 3, std::vector<float>(12)); }),
              "geometry mask: G-buffer positions: 12 values for 4x3 pixels of 4 channel(s), expected 48");
    EXPECT_EQ(errorOf([&] { differenceImage(a.view(), b.view()); }),
              "difference image: test image is 4x3, reference image is 3x4");
}

TEST(Metrics, GeometryMaskIsWhereThePositionsWIsNonZero)
{
    std::vector<float> positions(4 * 3, 0.0f);
    positions[3] = 1.0f;                       // pixel 0: geometry
    positions[4 * 2 + 0] = 5.0f;               // pixel 2: xyz but w = 0: background
    const PixelMask mask = geometryMask(3, 1, positions);
    EXPECT_EQ(mask.covered, (std::vector<uint8_t>{1, 0, 0}));
    EXPECT_EQ(mask.count(), 1u);
}

TEST(Metrics, ColorFiguresAverageTheChannels)
{
    // 2 x 1: pixel 0 equal, pixel 1 with G off by 60/255 and B by 15/255.
    const std::vector<uint8_t> reference{10, 20, 30, 255, 100, 100, 100, 255};
    const std::vector<uint8_t> test{10, 20, 30, 255, 100, 160, 85, 0};  // alpha is ignored
    const ColorComparison c = compareColor({2, 1, test}, {2, 1, reference});
    const double g = 60.0 / 255.0, b = 15.0 / 255.0;
    EXPECT_EQ(c.all.pixels, 2u);
    EXPECT_DOUBLE_EQ(c.all.rmse, std::sqrt((g * g + b * b) / 6.0));
    EXPECT_DOUBLE_EQ(c.all.mae, (g + b) / 6.0);
    EXPECT_DOUBLE_EQ(c.all.maxAbsError, g);
    EXPECT_EQ(c.all.maxX, 1u);
    EXPECT_EQ(c.maxChannel, 1u);
    EXPECT_DOUBLE_EQ(c.all.testAtMax, 160.0 / 255.0);
    EXPECT_EQ(c.all.pixelsAbove[0], 1u);  // the largest channel, 0.235 > 0.05
    EXPECT_EQ(c.all.pixelsAbove[1], 1u);  // 0.235 > 0.2
    EXPECT_EQ(toJson(c)["max_channel"], "G");

    const ColorComparison same = compareColor({2, 1, reference}, {2, 1, reference});
    EXPECT_EQ(same.all.rmse, 0.0);
    EXPECT_NEAR(same.ssimLuma, 1.0, 1e-12);
}

TEST(Metrics, ColorMaskAndLuma)
{
    const std::vector<uint8_t> white{255, 255, 255, 255, 0, 0, 0, 255};
    const std::vector<float> luma = colorLuma({2, 1, white});
    EXPECT_NEAR(luma[0], 1.0f, 1e-6f);  // BT.709 weights sum to 1
    EXPECT_EQ(luma[1], 0.0f);
    const std::vector<uint8_t> green{0, 255, 0, 255, 0, 0, 0, 255};
    EXPECT_NEAR(colorLuma({2, 1, green})[0], 0.7152f, 1e-6f);
    // Masked out, pixel 1's difference does not count.
    const std::vector<uint8_t> other{255, 255, 255, 255, 200, 0, 0, 255};
    const PixelMask mask{2, 1, {1, 0}};
    const ColorComparison c = compareColor({2, 1, other}, {2, 1, white}, &mask);
    EXPECT_EQ(c.geometryPixels, 1u);
    EXPECT_EQ(c.all.rmse, 0.0);
    EXPECT_NEAR(c.ssimLuma, 1.0, 1e-12);
}

TEST(Metrics, DifferenceImageUsesTheDivergingMap)
{
    Image reference(6, 1, 0.5f), test(6, 1, 0.5f);
    test.pixels = {0.5f, 1.0f, 0.0f, 0.6f, 0.25f, std::numeric_limits<float>::quiet_NaN()};
    const PixelMask mask{6, 1, {1, 1, 1, 1, 1, 1}};
    const std::vector<uint8_t> rgba = differenceImage(test.view(), reference.view(), &mask, 0.5f);
    const auto pixel = [&](size_t i) {
        return std::vector<int>{rgba[4 * i], rgba[4 * i + 1], rgba[4 * i + 2], rgba[4 * i + 3]};
    };
    EXPECT_EQ(pixel(0), (std::vector<int>{255, 255, 255, 255})) << "equal: white";
    EXPECT_EQ(pixel(1), (std::vector<int>{103, 0, 31, 255})) << "too lit by the full scale: darkest red";
    EXPECT_EQ(pixel(2), (std::vector<int>{5, 48, 97, 255})) << "too dark by the full scale: darkest blue";
    EXPECT_EQ(pixel(3), (std::vector<int>{253, 219, 199, 255})) << "+0.1 of 0.5: the first red stop";
    // -0.25 of 0.5: halfway along the blue stops, between #92c5de and #4393c3.
    EXPECT_EQ(pixel(4), (std::vector<int>{107, 172, 209, 255}));
    EXPECT_EQ(pixel(5), (std::vector<int>{0, 255, 0, 255})) << "not finite: green";

    const PixelMask background{6, 1, {0, 1, 1, 1, 1, 1}};
    const std::vector<uint8_t> masked = differenceImage(test.view(), reference.view(), &background, 0.5f);
    EXPECT_EQ((std::vector<int>{masked[0], masked[1], masked[2]}), (std::vector<int>{128, 128, 128}));

    // Beyond the full scale the colour stays at the darkest stop.
    const std::vector<uint8_t> narrow = differenceImage(test.view(), reference.view(), nullptr, 0.1f);
    EXPECT_EQ((std::vector<int>{narrow[4 * 4], narrow[4 * 4 + 1], narrow[4 * 4 + 2]}), (std::vector<int>{5, 48, 97}));

    EXPECT_EQ(errorOf([&] { differenceImage(test.view(), reference.view(), nullptr, 0.0f); }),
              "difference image: the full scale must be in (0, 1], got 0");
    EXPECT_EQ(errorOf([&] { differenceImage(test.view(), reference.view(), nullptr, std::nanf("")); }),
              "difference image: the full scale must be in (0, 1], got nan");
}

TEST(Metrics, VisibilityGreyscaleIsLinearInV)
{
    Image v(6, 1);
    v.pixels = {0.0f, 1.0f, 0.5f, -1.0f, 2.0f, std::numeric_limits<float>::infinity()};
    const std::vector<uint8_t> rgba = visibilityGreyscale(v.view());
    const std::vector<uint8_t> expected{0,   0,   0,   255, 255, 255, 255, 255, 128, 128, 128, 255,
                                        0,   0,   0,   255, 255, 255, 255, 255, 255, 0,   255, 255};
    EXPECT_EQ(rgba, expected);
}

TEST(Metrics, JsonCarriesEveryFigure)
{
    Image reference(4, 1), test(4, 1);
    reference.pixels = {0.0f, 0.5f, 1.0f, 1.0f};
    test.pixels = {0.25f, 0.5f, 1.0f, 0.75f};
    const nlohmann::json j = toJson(compareVisibility(test.view(), reference.view()));
    EXPECT_EQ(j["width"], 4);
    EXPECT_EQ(j["geometry_pixels"], 4);
    EXPECT_EQ(j["all"]["pixels"], 4);
    EXPECT_DOUBLE_EQ(j["all"]["rmse"].get<double>(), std::sqrt(2 * 0.0625 / 4));
    EXPECT_DOUBLE_EQ(j["all"]["mae"].get<double>(), 0.125);
    EXPECT_EQ(j["all"]["max_at"], (nlohmann::json{{"x", 0}, {"y", 0}, {"test", 0.25}, {"reference", 0.0}}));
    EXPECT_EQ(j["all"]["above"][0], (nlohmann::json{{"threshold", 0.05}, {"pixels", 2}, {"percent", 50.0}}));
    EXPECT_EQ(j["all"]["above"][1]["threshold"], 0.2);
    EXPECT_EQ(j["regions"]["umbra"]["pixels"], 1);
    EXPECT_EQ(j["regions"]["penumbra"]["pixels"], 1);
    EXPECT_EQ(j["regions"]["lit"]["pixels"], 2);
    EXPECT_EQ(j["region_bounds"], (nlohmann::json{{"umbra_max", 0.01}, {"lit_min", 0.99}}));
    EXPECT_EQ(j["invalid"]["test"], (nlohmann::json{{"non_finite", 0}, {"out_of_range", 0}}));
    EXPECT_TRUE(j["ssim"].is_number());
    expectAllFinite(j);
}

// ---- the Pareto front of (time, error) points -------------------------------------------

TEST(Pareto, FrontOfHandMadePoints)
{
    // index:               0          1          2          3           4          5          6
    const std::vector<TradeoffPoint> points = {{4.0, 0.10}, {1.0, 0.50}, {2.0, 0.20}, {3.0, 0.25}, {8.0, 0.10}, {2.0, 0.30},
                                               {16.0, 0.01}};
    // 3 is beaten by 2 (faster and better), 4 by 0 (slower, equal error), 5 by 2 (equal
    // time, worse error). The front runs from the fastest to the most accurate.
    EXPECT_EQ(paretoFront(points), (std::vector<size_t>{1, 2, 0, 6}));
}

TEST(Pareto, EdgeCases)
{
    EXPECT_TRUE(paretoFront(std::vector<TradeoffPoint>{}).empty());
    EXPECT_EQ(paretoFront(std::vector<TradeoffPoint>{{5.0, 0.5}}), std::vector<size_t>{0});
    // Equal points dominate each other in neither coordinate: both stay, in index order.
    EXPECT_EQ(paretoFront(std::vector<TradeoffPoint>{{2.0, 0.3}, {1.0, 0.4}, {2.0, 0.3}}), (std::vector<size_t>{1, 0, 2}));
    // One point best in both: the front is that point alone.
    EXPECT_EQ(paretoFront(std::vector<TradeoffPoint>{{3.0, 0.3}, {1.0, 0.1}, {2.0, 0.2}}), std::vector<size_t>{1});
    // Zero time (no timestamps) and zero error are ordinary values; NaN takes no part,
    // neither on the front nor hiding a point it would otherwise beat.
    const double nan = std::numeric_limits<double>::quiet_NaN();
    EXPECT_EQ(paretoFront(std::vector<TradeoffPoint>{{0.0, 0.2}, {nan, 0.0}, {1.0, 0.0}, {0.5, nan}}),
              (std::vector<size_t>{0, 2}));
    // An infinite error is still a point: alone, it is the front.
    EXPECT_EQ(paretoFront(std::vector<TradeoffPoint>{{1.0, std::numeric_limits<double>::infinity()}}), std::vector<size_t>{0});
}

TEST(Pareto, NoFrontPointIsDominatedAndEveryOtherPointIs)
{
    // The definition, checked directly on random points with many ties.
    std::mt19937 rng(7);
    std::uniform_int_distribution<int> coordinate(0, 9);
    for (int trial = 0; trial < 50; ++trial) {
        std::vector<TradeoffPoint> points(20);
        for (TradeoffPoint& p : points) p = {double(coordinate(rng)), double(coordinate(rng)) / 10.0};
        const std::vector<size_t> front = paretoFront(points);
        const auto dominates = [](const TradeoffPoint& a, const TradeoffPoint& b) {
            return a.timeMs <= b.timeMs && a.error <= b.error && (a.timeMs < b.timeMs || a.error < b.error);
        };
        for (size_t i = 0; i < points.size(); ++i) {
            const bool dominated = std::any_of(points.begin(), points.end(), [&](const TradeoffPoint& q) { return dominates(q, points[i]); });
            const bool onFront = std::find(front.begin(), front.end(), i) != front.end();
            EXPECT_NE(dominated, onFront) << "trial " << trial << " point " << i;
        }
        for (size_t k = 1; k < front.size(); ++k) {
            EXPECT_LE(points[front[k - 1]].timeMs, points[front[k]].timeMs);
            EXPECT_GE(points[front[k - 1]].error, points[front[k]].error);
        }
    }
}
