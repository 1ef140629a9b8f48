#include "penumbra/config/Overrides.h"

#include "core/Text.h"
#include "penumbra/core/Error.h"
#include "penumbra/core/ShortText.h"

#include <fmt/format.h>

#include <algorithm>

using nlohmann::json;

namespace penumbra::config {

ParamOverride parseParamOverride(std::string_view setting)
{
    const size_t eq = setting.find('=');
    const std::string_view key = setting.substr(0, eq);
    const size_t dot = key.find('.');
    if (eq == std::string_view::npos || dot == std::string_view::npos || dot == 0 || dot + 1 == key.size()) {
        throw ConfigError(fmt::format("--set '{}': expected technique.parameter=value, e.g. --set hard.pcf_kernel=5",
                                      core::shortText(setting)));
    }
    ParamOverride o;
    o.technique = std::string(key.substr(0, dot));
    o.param = std::string(key.substr(dot + 1));
    const std::string text(setting.substr(eq + 1));
    o.value = json::parse(text, nullptr, false);
    if (o.value.is_discarded()) o.value = text;
    o.where = fmt::format("--set {}", core::shortText(key));
    return o;
}

std::vector<ParamOverride> parseParamOverrides(const std::vector<std::string>& settings)
{
    std::vector<ParamOverride> overrides;
    for (const std::string& s : settings) overrides.push_back(parseParamOverride(s));
    return overrides;
}

void applyParamOverrides(RenderConfig& config, const std::vector<ParamOverride>& overrides)
{
    for (const ParamOverride& o : overrides) {
        bool used = false;
        for (LightConfig& light : config.lights) {
            if (light.shadow.technique != o.technique) continue;
            light.shadow.setParam(o.param, o.value, o.where);
            used = true;
        }
        if (used) continue;
        std::vector<std::string> techniques;
        for (const LightConfig& light : config.lights)
            if (std::find(techniques.begin(), techniques.end(), light.shadow.technique) == techniques.end()) {
                techniques.push_back(light.shadow.technique);
            }
        std::string hint = techniques.empty() ? "the config has no lights"
                                              : fmt::format("its lights use: {}", fmt::join(techniques, ", "));
        if (const std::string best = core::closestMatch(o.technique, techniques); !best.empty()) {
            hint += fmt::format("; did you mean '{}'?", best);
        }
        throw ConfigError(fmt::format("{}: no light of {} uses technique '{}' ({})", o.where, displayPath(config.file),
                                      core::shortText(o.technique), hint));
    }
}

std::vector<ParamOverride> overridesUsedBy(const std::vector<ParamOverride>& overrides, const RenderConfig& config)
{
    std::vector<ParamOverride> used;
    for (const ParamOverride& o : overrides) {
        const bool named = std::any_of(config.lights.begin(), config.lights.end(),
                                       [&](const LightConfig& l) { return l.shadow.technique == o.technique; });
        if (named) used.push_back(o);
    }
    return used;
}

} // namespace penumbra::config
