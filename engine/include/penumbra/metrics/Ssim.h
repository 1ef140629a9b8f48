#pragma once
// Structural similarity, after Z. Wang, A. C. Bovik, H. R. Sheikh, E. P. Simoncelli,
// "Image Quality Assessment: From Error Visibility to Structural Similarity", IEEE Trans.
// Image Processing 13(4), 2004:
//   SSIM(x, y) = (2 μx μy + C1)(2 σxy + C2) / ((μx² + μy² + C1)(σx² + σy² + C2))   (eq. 13)
// with local statistics under an 11x11 circular-symmetric Gaussian window, σ = 1.5
// (sec. III-C), C1 = (K1 L)², C2 = (K2 L)², K1 = 0.01, K2 = 0.03, and the mean over the
// image as the figure (eq. 17). L is the dynamic range: 1 for visibility and for colour
// values scaled to [0, 1].
//
// Masked and bordered windows: the window's weights are restricted to pixels inside the
// image and inside the mask and renormalised (normalised convolution), so background and
// the outside of the image never enter the statistics; the paper's window is the special
// case of a window fully inside. The mean is taken over the mask's pixels.
#include "penumbra/metrics/Images.h"

namespace penumbra::metrics {

inline constexpr int kSsimWindowRadius = 5;  // 11x11 window
inline constexpr double kSsimSigma = 1.5;    // Gaussian σ in pixels
inline constexpr double kSsimK1 = 0.01;
inline constexpr double kSsimK2 = 0.03;

// Mean SSIM of `a` against `b` over the pixels of `mask` (all pixels when null) with
// dynamic range `dynamicRange`. A pixel where either image is not finite counts as
// outside the mask. Returns 1 when no pixel is left (nothing differs). Symmetric in a
// and b. Throws Error naming both sizes when the images or the mask differ in size.
double meanSsim(FloatImageView a, FloatImageView b, const PixelMask* mask = nullptr, double dynamicRange = 1.0);

} // namespace penumbra::metrics
