#include "penumbra/metrics/Ssim.h"

#include "metrics/ImageChecks.h"
#include "penumbra/core/Error.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>

namespace penumbra::metrics {
namespace {

constexpr int kWindowTaps = 2 * kSsimWindowRadius + 1;

// The moments each window sums, weighted by mask x Gaussian: 1, a, b, a², b², a·b.
constexpr size_t kMoments = 6;
using Moments = std::array<double, kMoments>;

std::array<double, kWindowTaps> gaussianTaps()
{
    std::array<double, kWindowTaps> taps{};
    double sum = 0.0;
    for (int k = -kSsimWindowRadius; k <= kSsimWindowRadius; ++k) {
        taps[size_t(k + kSsimWindowRadius)] = std::exp(-double(k * k) / (2.0 * kSsimSigma * kSsimSigma));
        sum += taps[size_t(k + kSsimWindowRadius)];
    }
    for (double& t : taps) t /= sum;
    return taps;
}

// The 2D Gaussian is separable, and so is the masked sum (the mask is one of the summed
// moments): a horizontal pass per row into a ring of the 2r + 1 rows a vertical sum
// needs, then the vertical pass per output pixel. The ring keeps the memory at
// 11 rows x width x 6 doubles whatever the image height.
class MomentRows {
public:
    MomentRows(FloatImageView a, FloatImageView b, const std::vector<uint8_t>& compared)
        : a_(a), b_(b), compared_(compared), taps_(gaussianTaps()),
          rows_(size_t(kWindowTaps) * a.width)
    {
    }

    // Makes the horizontal sums of rows up to `last` available.
    void computeThrough(uint32_t last)
    {
        for (; next_ <= last; ++next_) computeRow(next_);
    }

    const Moments& at(uint32_t x, uint32_t y) const { return rows_[size_t(y % kWindowTaps) * a_.width + x]; }

private:
    void computeRow(uint32_t y)
    {
        const size_t rowStart = size_t(y) * a_.width;
        Moments* out = &rows_[size_t(y % kWindowTaps) * a_.width];
        const int width = int(a_.width);
        for (int x = 0; x < width; ++x) {
            Moments sum{};
            const int from = std::max(0, x - kSsimWindowRadius), to = std::min(width - 1, x + kSsimWindowRadius);
            for (int i = from; i <= to; ++i) {
                const size_t p = rowStart + size_t(i);
                if (!compared_[p]) continue;
                const double g = taps_[size_t(i - x + kSsimWindowRadius)];
                const double va = a_.pixels[p], vb = b_.pixels[p];
                sum[0] += g;
                sum[1] += g * va;
                sum[2] += g * vb;
                sum[3] += g * (va * va);
                sum[4] += g * (vb * vb);
                sum[5] += g * (va * vb);  // bracketed: exactly symmetric in a and b
            }
            out[x] = sum;
        }
    }

    FloatImageView a_, b_;
    const std::vector<uint8_t>& compared_;
    std::array<double, kWindowTaps> taps_;
    std::vector<Moments> rows_;
    uint32_t next_ = 0;
};

} // namespace

double meanSsim(FloatImageView a, FloatImageView b, const PixelMask* mask, double dynamicRange)
{
    checkComparable("SSIM", {"first image", a.width, a.height, a.pixels.size()},
                    {"second image", b.width, b.height, b.pixels.size()}, 1, mask);
    if (!(std::isfinite(dynamicRange) && dynamicRange > 0.0)) {
        throw Error(fmt::format("SSIM: the dynamic range must be a finite number > 0, got {}", dynamicRange));
    }
    const double c1 = (kSsimK1 * dynamicRange) * (kSsimK1 * dynamicRange);
    const double c2 = (kSsimK2 * dynamicRange) * (kSsimK2 * dynamicRange);

    std::vector<uint8_t> compared(a.pixels.size());
    for (size_t i = 0; i < compared.size(); ++i) {
        compared[i] = (!mask || mask->covered[i]) && std::isfinite(a.pixels[i]) && std::isfinite(b.pixels[i]);
    }

    const std::array<double, kWindowTaps> taps = gaussianTaps();
    MomentRows rows(a, b, compared);
    double ssimSum = 0.0;
    uint64_t count = 0;
    const int height = int(a.height);
    for (int y = 0; y < height; ++y) {
        rows.computeThrough(uint32_t(std::min(height - 1, y + kSsimWindowRadius)));
        const int from = std::max(0, y - kSsimWindowRadius), to = std::min(height - 1, y + kSsimWindowRadius);
        for (uint32_t x = 0; x < a.width; ++x) {
            if (!compared[size_t(y) * a.width + x]) continue;
            Moments s{};
            for (int j = from; j <= to; ++j) {
                const double g = taps[size_t(j - y + kSsimWindowRadius)];
                const Moments& h = rows.at(x, uint32_t(j));
                for (size_t m = 0; m < kMoments; ++m) s[m] += g * h[m];
            }
            // s[0] > 0: the window's own centre pixel is compared and carries the largest weight.
            const double w = s[0];
            const double muA = s[1] / w, muB = s[2] / w;
            // E[x²] - μ² can come out a hair below 0 through round-off on flat windows.
            const double varA = std::max(0.0, s[3] / w - muA * muA);
            const double varB = std::max(0.0, s[4] / w - muB * muB);
            const double covAB = s[5] / w - muA * muB;
            // Both factors of the denominator are >= C1 > 0 and >= C2 > 0.
            ssimSum += ((2.0 * muA * muB + c1) * (2.0 * covAB + c2)) / ((muA * muA + muB * muB + c1) * (varA + varB + c2));
            ++count;
        }
    }
    return count > 0 ? ssimSum / double(count) : 1.0;
}

} // namespace penumbra::metrics
