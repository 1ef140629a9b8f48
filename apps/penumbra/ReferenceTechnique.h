#pragma once
// The technique that `compare` and `bench` measure every light's technique against:
// `--reference NAME` (the plugin; "reference" by default) with `--reference-set
// param=value` (or NAME.param=value) for its parameters, and none of the techniques'
// under test.
#include "penumbra/config/Config.h"
#include "penumbra/plugin/PluginRegistry.h"

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace penumbra::app {

struct ReferenceTechnique {
    // Required: a reference that cannot run must stop the measurement, never let a light
    // be compared against an unshadowed one.
    config::ShadowSettings shadow;
    nlohmann::json params;  // every parameter as the plugin resolves it, for reports
};

// Loads the plugin and checks the --reference-set values against its parameters, before
// anything renders. Throws penumbra::Error naming the flag.
ReferenceTechnique loadReferenceTechnique(const std::string& name, const std::vector<std::string>& settings,
                                          plugin::PluginRegistry& plugins);

// `config` with every light shadowed by the reference technique.
config::RenderConfig withReferenceShadows(config::RenderConfig config, const ReferenceTechnique& reference);

} // namespace penumbra::app
