#pragma once
// `penumbra render cfg.json -o out.png`: renders a config headless to a PNG, or every
// frame of an animated run to numbered PNGs; optionally prints per-pass timings and
// culling figures.
#include "CommandLine.h"

namespace penumbra::app {

Command addRenderCommand(CLI::App& app);

} // namespace penumbra::app
