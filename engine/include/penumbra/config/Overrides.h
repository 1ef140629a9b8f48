#pragma once
// Technique parameters set on the command line: `--set hard.pcf_kernel=5` sets
// pcf_kernel for every light whose shadow technique is "hard", on top of the config
// (the plugin's reflection checks the value later, naming "--set hard.pcf_kernel").
#include "penumbra/config/RenderConfig.h"

#include <nlohmann/json.hpp>

#include <string>
#include <string_view>
#include <vector>

namespace penumbra::config {

struct ParamOverride {
    std::string technique;  // "hard"
    std::string param;      // "pcf_kernel"
    nlohmann::json value;   // 5
    std::string where;      // "--set hard.pcf_kernel": the ShadowParam::where of the value
};

// Parses "technique.param=value". The value is JSON when it parses as JSON (5, 0.5,
// true, "quoted text"), else the text itself (pcf), so enum choices need no quotes.
// Throws ConfigError for any other shape.
ParamOverride parseParamOverride(std::string_view setting);
std::vector<ParamOverride> parseParamOverrides(const std::vector<std::string>& settings);

// Sets each override on every light whose technique it names, in order (a later one
// wins). Throws ConfigError when no light uses the technique. Lights that come from a
// glTF file ("lights": "scene") exist only after buildScene: config::prepareRun
// (config/Run.h) applies the overrides after it.
void applyParamOverrides(RenderConfig& config, const std::vector<ParamOverride>& overrides);

// The overrides whose technique one of `config`'s lights uses (a sweep variant's share of
// overrides meant for several variants).
std::vector<ParamOverride> overridesUsedBy(const std::vector<ParamOverride>& overrides, const RenderConfig& config);

} // namespace penumbra::config
