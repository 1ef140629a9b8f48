#pragma once
// What `compare` and `bench` share about a rendered frame: the frame they measure a
// config at, and what they read back from the renderer for the metrics.
#include "penumbra/config/Config.h"
#include "penumbra/config/Overrides.h"
#include "penumbra/frame/FrameRenderer.h"
#include "penumbra/scene/Scene.h"

#include <cstdint>
#include <string>
#include <vector>

namespace penumbra::app {

// Builds the config's scene, applies the --set overrides (after buildScene: "lights":
// "scene" configs have their lights only then) and poses an animated config at its first
// frame, as `render` shows it: compare and bench measure frame 0.
scene::Scene buildFirstFrame(config::RenderConfig& config, const std::vector<config::ParamOverride>& overrides);

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
