#pragma once
// Values of a plugin's reflected parameters (plugin/Plugin.h ParamSpec): defaults,
// overridden from the config ("shadow": {"technique": "hard", "pcf_kernel": 5}) and the
// command line (--set hard.pcf_kernel=5), each checked against the spec's type, range
// and choices with an error that says where the value came from.
#include "penumbra/config/Config.h"
#include "penumbra/plugin/Plugin.h"

#include <nlohmann/json.hpp>

#include <string>
#include <string_view>
#include <vector>

namespace penumbra::plugin {

struct LoadedPlugin;
class PluginMetadata;

class ParamValues {
public:
    ParamValues() = default;
    // Every parameter at its default. `specs` must be sane (checkPluginInfo in
    // plugin/PluginRegistry.h; a loaded plugin's are).
    ParamValues(std::string pluginName, const ParamSpec* specs, uint32_t count);

    // Sets one parameter. `where` names the value's origin for messages ("a.json:
    // /lights/0/shadow/pcf_kernel", "--set hard.pcf_kernel"). Throws penumbra::ConfigError
    // for an unknown name (with "did you mean"), a wrong type, a value out of range, an
    // unknown choice. Enum values are given by choice name; Int accepts integral numbers
    // only (5 or 5.0, not 5.5); Float any finite number; Bool accepts true/false.
    void set(std::string_view name, const nlohmann::json& value, const std::string& where);

    // Getters throw penumbra::Error for an unknown name or a getter of another type: a
    // programmer error in the plugin, not bad input.
    bool getBool(std::string_view name) const;
    int getInt(std::string_view name) const;
    float getFloat(std::string_view name) const;
    // Enum: the choice's name, and its index in ParamSpec::choices.
    std::string_view getEnum(std::string_view name) const;
    uint32_t getEnumIndex(std::string_view name) const;

    const std::string& pluginName() const { return plugin_; }
    const std::vector<ParamSpec>& specs() const { return specs_; }
    // {"pcf_kernel": 5, "filter": "pcf", ...}: current values, typed as JSON.
    nlohmann::json toJson() const;

private:
    size_t indexOf(std::string_view name, ParamType expected) const;
    std::string plugin_;
    std::vector<ParamSpec> specs_;
    std::vector<double> values_;
};

// One spec as JSON (name, type, default, min, max, unit, doc, choices): for
// `penumbra plugins --json`.
nlohmann::json specToJson(const ParamSpec& spec);
const char* paramTypeName(ParamType type);

// The values one light's technique gets: the plugin's defaults, then every parameter the
// light's "shadow" object (or --set) gives, in order. Each error names the value's
// `where` (config/Config.h ShadowParam). Throws penumbra::ConfigError at the first bad
// value; with `errors`, appends every bad value's message there instead (a bad value
// keeps its default) and throws nothing, so that a check can report them all.
ParamValues resolveParams(const LoadedPlugin& plugin, const config::ShadowSettings& shadow,
                          std::vector<std::string>* errors = nullptr);
// The same from a plugin's scanned description (`validate` checks configs with these).
ParamValues resolveParams(const PluginMetadata& plugin, const config::ShadowSettings& shadow,
                          std::vector<std::string>* errors = nullptr);

} // namespace penumbra::plugin
