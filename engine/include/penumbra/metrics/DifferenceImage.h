#pragma once
// Images to look at next to the figures: a visibility image as greyscale and the signed
// difference of two as false colour. Both are RGBA8 for io::writePng.
#include "penumbra/metrics/Images.h"

#include <cstdint>
#include <vector>

namespace penumbra::metrics {

// |ΔV| at which the difference image's colours saturate, unless the caller says otherwise:
// half the visibility range, so that an error of 0.05 is still a visible tint.
inline constexpr float kDefaultDifferenceFullScale = 0.5f;

// ΔV = test - reference as a diverging colour map (ColorBrewer RdBu, C. Brewer,
// colorbrewer2.org, with a pure white centre): white where equal, red where the test is
// too lit (ΔV > 0), blue where it is too dark, too shadowed (ΔV < 0); the colour runs
// through the map's five stops per side linearly in |ΔV| / fullScale and is the darkest
// stop from |ΔV| >= fullScale on. Background (mask 0) is mid grey (128, 128, 128); a
// pixel where either value is not finite is green (0, 255, 0). Throws Error naming both
// sizes when the images or the mask differ in size, or when fullScale is not in (0, 1].
std::vector<uint8_t> differenceImage(FloatImageView test, FloatImageView reference, const PixelMask* mask = nullptr,
                                     float fullScale = kDefaultDifferenceFullScale);

// V as grey: byte = round(255 * clamp(V, 0, 1)), linear in V (not sRGB-encoded), so that
// a byte read back is V to within 1/510; a non-finite value is magenta (255, 0, 255).
std::vector<uint8_t> visibilityGreyscale(FloatImageView visibility);

} // namespace penumbra::metrics
