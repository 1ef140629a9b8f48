#pragma once
// `penumbra compare cfg.json`: renders the config with each light's own technique, then
// again with every light's technique replaced by the reference technique, and measures
// each light's visibility image and the colour image against the reference's
// (metrics/ImageComparison.h); optionally writes the images and the figures to a folder.
// Exit codes as `render`: 0 done, 3 when the validation layer reported anything.
// `penumbra compare A.exr B.exr`: the same figures for every channel of two OpenEXR files
// (VisibilityExr.h), B the reference; no device.
#include "CommandLine.h"

namespace penumbra::app {

Command addCompareCommand(CLI::App& app);

} // namespace penumbra::app
