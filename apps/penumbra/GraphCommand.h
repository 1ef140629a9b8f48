#pragma once
// `penumbra graph cfg.json`: the frame's compiled render graph as text or Graphviz.
#include "penumbra/gpu/Context.h"

#include <optional>
#include <string>
#include <vector>

namespace penumbra::app {

struct GraphFlags {
    std::string config;
    std::string format = "text";  // "text" or "dot"
    std::string output;           // empty: stdout
    std::optional<uint32_t> width;
    std::optional<uint32_t> height;
    std::vector<std::string> settings;  // --set technique.param=value
};

// Builds the config's frame (plugins, techniques, graph), executes it once so that the
// memory figures are the device's own, and prints the compiled graph; as text, followed
// by the culling that ran outside the graph (the visibility service's submissions).
int runGraph(const GraphFlags& flags, const gpu::ContextOptions& device);

} // namespace penumbra::app
