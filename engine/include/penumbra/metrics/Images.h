#pragma once
// The images the metrics read, as the renderer reads them back (frame/FrameRenderer.h),
// and the mask of pixels that hold geometry. Pure CPU: nothing here touches Vulkan.
#include <cstdint>
#include <span>
#include <vector>

namespace penumbra::metrics {

// One float per pixel, top row first: a visibility image V_l (FrameRenderer::readVisibility)
// or any other scalar image (luma). Does not own its pixels.
struct FloatImageView {
    uint32_t width = 0;
    uint32_t height = 0;
    std::span<const float> pixels;
};

// sRGB-encoded RGBA8, four bytes per pixel, top row first (FrameRenderer::readColor).
struct Rgba8ImageView {
    uint32_t width = 0;
    uint32_t height = 0;
    std::span<const uint8_t> pixels;
};

// The pixels to compare: those that hold geometry. Background pixels (where no surface
// was drawn) have no visibility to speak of; techniques leave whatever there.
struct PixelMask {
    uint32_t width = 0;
    uint32_t height = 0;
    std::vector<uint8_t> covered;  // one per pixel: 1 = compare, 0 = background

    uint64_t count() const;
};

// The pixels whose G-buffer world position has w != 0 (the G-buffer writes w = 1 where a
// surface is drawn and clears to 0): `positions` holds four floats per pixel, as
// FrameRenderer::readPositions returns them. Throws Error when the size does not match.
PixelMask geometryMask(uint32_t width, uint32_t height, std::span<const float> positions);

} // namespace penumbra::metrics
