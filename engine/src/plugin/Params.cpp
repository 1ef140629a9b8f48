#include "penumbra/plugin/Params.h"

#include "core/Text.h"
#include "penumbra/core/Error.h"
#include "penumbra/core/ShortText.h"
#include "penumbra/plugin/PluginRegistry.h"

#include <fmt/format.h>

#include <cmath>
#include <optional>

using nlohmann::json;

namespace penumbra::plugin {
namespace {

std::vector<std::string> choiceNames(const ParamSpec& spec)
{
    return std::vector<std::string>(spec.choices, spec.choices + spec.choiceCount);
}

// What a value must be, for messages: "an integer in [1, 15]".
std::string expectation(const ParamSpec& spec)
{
    switch (spec.type) {
    case ParamType::Bool: return "true or false";
    case ParamType::Int:
        return fmt::format("{} in [{}, {}]", spec.odd ? "an odd integer" : "an integer", spec.minValue, spec.maxValue);
    case ParamType::Float: return fmt::format("a number in [{}, {}]", spec.minValue, spec.maxValue);
    case ParamType::Enum: {
        std::vector<std::string> quoted;
        for (const std::string& c : choiceNames(spec)) quoted.push_back('"' + c + '"');
        return fmt::format("one of {}", fmt::join(quoted, ", "));
    }
    }
    return "?";
}

// The value as stored (double; Enum: the choice's index), or nullopt when `value` does
// not fit the spec.
std::optional<double> convert(const ParamSpec& spec, const json& value)
{
    switch (spec.type) {
    case ParamType::Bool:
        if (!value.is_boolean()) return std::nullopt;
        return value.get<bool>() ? 1.0 : 0.0;
    case ParamType::Int:
    case ParamType::Float: {
        if (!value.is_number()) return std::nullopt;
        const double x = value.get<double>();
        if (!std::isfinite(x) || x < spec.minValue || x > spec.maxValue) return std::nullopt;
        if (spec.type == ParamType::Int && x != std::floor(x)) return std::nullopt;
        if (spec.odd && std::fmod(x, 2.0) == 0.0) return std::nullopt;
        return x;
    }
    case ParamType::Enum:
        if (!value.is_string()) return std::nullopt;
        for (uint32_t i = 0; i < spec.choiceCount; ++i)
            if (value.get<std::string>() == spec.choices[i]) return double(i);
        return std::nullopt;
    }
    return std::nullopt;
}

json typedValue(const ParamSpec& spec, double value)
{
    switch (spec.type) {
    case ParamType::Bool: return value != 0.0;
    case ParamType::Int: return int64_t(value);
    case ParamType::Float: return value;
    case ParamType::Enum: return spec.choices[size_t(value)];
    }
    return nullptr;
}

} // namespace

const char* paramTypeName(ParamType type)
{
    switch (type) {
    case ParamType::Bool: return "bool";
    case ParamType::Int: return "int";
    case ParamType::Float: return "float";
    case ParamType::Enum: return "enum";
    }
    return "unknown";
}

ParamValues::ParamValues(std::string pluginName, const ParamSpec* specs, uint32_t count)
    : plugin_(std::move(pluginName)), specs_(specs, specs + count)
{
    values_.reserve(count);
    for (const ParamSpec& spec : specs_) values_.push_back(spec.defaultValue);
}

void ParamValues::set(std::string_view name, const json& value, const std::string& where)
{
    size_t index = specs_.size();
    std::vector<std::string> names;
    for (size_t i = 0; i < specs_.size(); ++i) {
        names.emplace_back(specs_[i].name);
        if (names.back() == name) index = i;
    }
    if (index == specs_.size()) {
        const std::string best = core::closestMatch(name, names);
        const std::string known = names.empty() ? "it has none" : fmt::format("it has: {}", fmt::join(names, ", "));
        throw ConfigError(best.empty()
                              ? fmt::format("{}: plugin '{}' has no parameter '{}' ({})", where, plugin_,
                                            core::shortText(name), known)
                              : fmt::format("{}: plugin '{}' has no parameter '{}'; did you mean '{}'? ({})", where, plugin_,
                                            core::shortText(name), best, known));
    }
    const ParamSpec& spec = specs_[index];
    const std::optional<double> converted = convert(spec, value);
    if (!converted) {
        std::string hint;
        if (spec.type == ParamType::Enum && value.is_string()) {
            const std::string best = core::closestMatch(value.get<std::string>(), choiceNames(spec));
            if (!best.empty()) hint = fmt::format("; did you mean \"{}\"?", best);
        }
        throw ConfigError(fmt::format("{}: must be {} (plugin {}, parameter {}: {}), got {}{}", where, expectation(spec),
                                      plugin_, spec.name, spec.doc, core::shortJson(value), hint));
    }
    values_[index] = *converted;
}

size_t ParamValues::indexOf(std::string_view name, ParamType expected) const
{
    for (size_t i = 0; i < specs_.size(); ++i) {
        if (specs_[i].name != name) continue;
        if (specs_[i].type != expected) {
            throw Error(fmt::format("plugin '{}': parameter '{}' is of type {}, read as {}", plugin_, name,
                                    paramTypeName(specs_[i].type), paramTypeName(expected)));
        }
        return i;
    }
    throw Error(fmt::format("plugin '{}': no parameter '{}' is declared (read by name in the plugin's code)", plugin_, name));
}

bool ParamValues::getBool(std::string_view name) const { return values_[indexOf(name, ParamType::Bool)] != 0.0; }

int ParamValues::getInt(std::string_view name) const { return int(values_[indexOf(name, ParamType::Int)]); }

float ParamValues::getFloat(std::string_view name) const { return float(values_[indexOf(name, ParamType::Float)]); }

std::string_view ParamValues::getEnum(std::string_view name) const
{
    const size_t i = indexOf(name, ParamType::Enum);
    return specs_[i].choices[size_t(values_[i])];
}

uint32_t ParamValues::getEnumIndex(std::string_view name) const { return uint32_t(values_[indexOf(name, ParamType::Enum)]); }

json ParamValues::toJson() const
{
    json out = json::object();
    for (size_t i = 0; i < specs_.size(); ++i) out[specs_[i].name] = typedValue(specs_[i], values_[i]);
    return out;
}

json specToJson(const ParamSpec& spec)
{
    json out = {{"name", spec.name},
                {"type", paramTypeName(spec.type)},
                {"default", typedValue(spec, spec.defaultValue)},
                {"unit", spec.unit},
                {"doc", spec.doc}};
    if (spec.type == ParamType::Int || spec.type == ParamType::Float) {
        out["min"] = typedValue(spec, spec.minValue);
        out["max"] = typedValue(spec, spec.maxValue);
    }
    if (spec.type == ParamType::Enum) out["choices"] = choiceNames(spec);
    if (spec.odd) out["odd"] = true;
    return out;
}

namespace {

ParamValues resolveFrom(ParamValues values, const config::ShadowSettings& shadow, std::vector<std::string>* errors)
{
    if (shadow.technique != values.pluginName()) {
        throw Error(fmt::format("resolveParams: the light's technique is '{}', the plugin is '{}'", shadow.technique,
                                values.pluginName()));
    }
    for (const config::ShadowParam& p : shadow.params) {
        try {
            values.set(p.name, p.value, p.where);
        } catch (const ConfigError& e) {
            if (!errors) throw;
            errors->push_back(e.what());
        }
    }
    return values;
}

} // namespace

ParamValues resolveParams(const LoadedPlugin& plugin, const config::ShadowSettings& shadow, std::vector<std::string>* errors)
{
    return resolveFrom(plugin.defaultParams(), shadow, errors);
}

ParamValues resolveParams(const PluginMetadata& plugin, const config::ShadowSettings& shadow, std::vector<std::string>* errors)
{
    return resolveFrom(plugin.defaultParams(), shadow, errors);
}

} // namespace penumbra::plugin
