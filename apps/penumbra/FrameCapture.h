#pragma once
// What `compare` and `bench` read back from the renderer for the metrics.
#include "penumbra/frame/FrameRenderer.h"

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

} // namespace penumbra::app
