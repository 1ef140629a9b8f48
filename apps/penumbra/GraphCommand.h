#pragma once
// `penumbra graph cfg.json`: builds the config's frame (plugins, techniques, graph),
// executes it once so that the memory figures are the device's own, and prints the
// compiled graph as text or Graphviz.
#include "CommandLine.h"

namespace penumbra::app {

Command addGraphCommand(CLI::App& app);

} // namespace penumbra::app
