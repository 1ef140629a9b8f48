#include "ReferenceTechnique.h"

#include "penumbra/config/Overrides.h"
#include "penumbra/core/Error.h"
#include "penumbra/core/ShortText.h"

#include <fmt/format.h>

namespace penumbra::app {
namespace {

// "--reference-set samples=64", or with the reference's name as for --set:
// "--reference-set reference.samples=64".
config::ParamOverride parseReferenceSetting(const std::string& reference, const std::string& setting)
{
    const size_t eq = setting.find('=');
    std::string key = setting.substr(0, eq);
    if (const size_t dot = key.find('.'); dot != std::string::npos) {
        if (key.substr(0, dot) != reference) {
            throw Error(fmt::format("--reference-set '{}': '{}' is not the reference technique '{}' (--set sets the "
                                    "parameters of the techniques under test)",
                                    core::shortText(setting), core::shortText(key.substr(0, dot)), reference));
        }
        key = key.substr(dot + 1);
    }
    if (eq == std::string::npos || key.empty()) {
        throw Error(fmt::format("--reference-set '{}': expected parameter=value, e.g. --reference-set samples=64",
                                core::shortText(setting)));
    }
    config::ParamOverride o = config::parseParamOverride(fmt::format("{}.{}{}", reference, key, setting.substr(eq)));
    o.where = fmt::format("--reference-set {}", core::shortText(key));
    return o;
}

} // namespace

ReferenceTechnique loadReferenceTechnique(const std::string& name, const std::vector<std::string>& settings,
                                          plugin::PluginRegistry& plugins)
{
    ReferenceTechnique reference;
    reference.shadow.technique = name;
    reference.shadow.required = true;
    for (const std::string& setting : settings) {
        config::ParamOverride o = parseReferenceSetting(name, setting);
        reference.shadow.setParam(std::move(o.param), std::move(o.value), std::move(o.where));
    }
    const plugin::LoadedPlugin* loaded = nullptr;
    try {
        loaded = &plugins.load(name);
    } catch (const plugin::PluginError& e) {
        throw Error(fmt::format("--reference {}: {}", core::shortText(name), e.what()));
    }
    std::vector<std::string> errors;
    reference.params = plugin::resolveParams(*loaded, reference.shadow, &errors).toJson();
    if (!errors.empty()) throw Error(fmt::format("{}", fmt::join(errors, "\n")));
    return reference;
}

config::RenderConfig withReferenceShadows(config::RenderConfig config, const ReferenceTechnique& reference)
{
    for (config::LightConfig& light : config.lights) light.shadow = reference.shadow;
    return config;
}

} // namespace penumbra::app
