#pragma once
// What `compare`, `bench` and the viewer's comparison read back from the renderer for the
// metrics.
#include "penumbra/frame/FrameRenderer.h"
#include "penumbra/metrics/Images.h"
#include "penumbra/scene/Scene.h"

#include <span>

#include <cstdint>
#include <string>
#include <vector>

namespace penumbra::app {

// A rendered frame as the metrics read it.
struct FrameImages {
    uint32_t width = 0;
    uint32_t height = 0;
    std::vector<uint8_t> color;                  // sRGB RGBA8
    std::vector<std::vector<float>> visibility;  // V_l per light
    std::vector<float> positions;                // G-buffer world positions (w = 0: background)
    std::vector<std::string> techniques;         // per light; empty: rendered unshadowed (fallback)
};

// Reads back the last frame `renderer` rendered.
FrameImages captureFrame(const frame::FrameRenderer& renderer);

// The pixels where `light`'s figures are taken: those of geometry (metrics::geometryMask)
// that the light can reach. Outside a spot light's outer cone it gives no light at all:
// the techniques write V = 1 there by contract (the map has nothing to say) while the
// reference traces rays, so those pixels would score errors that no image shows
// (docs/plugins.md, "The contract"). Every other light reaches every pixel.
metrics::PixelMask reachMask(const scene::Light& light, uint32_t width, uint32_t height,
                             std::span<const float> positions);

} // namespace penumbra::app
