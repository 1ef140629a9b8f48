#include "penumbra/plugin/PluginMetadata.h"

#include "penumbra/plugin/PluginRegistry.h"

#include <fmt/format.h>

#include <deque>
#include <functional>

using nlohmann::json;
namespace fs = std::filesystem;

namespace penumbra::plugin {

// Deques: adding a string never moves the ones added before, which params_ points at.
struct PluginMetadata::Strings {
    std::deque<std::string> text;
    std::deque<std::vector<const char*>> choiceLists;
};

namespace {

// Stands in for the factory when metadata is checked as an entry's info: the scanner
// checked the real one, and metadata never creates a technique.
Technique* metadataHasNoFactory(const TechniqueSetup&) { return nullptr; }

ParamType paramTypeNamed(const std::string& name, const std::function<void(std::string)>& fail)
{
    for (ParamType type : {ParamType::Bool, ParamType::Int, ParamType::Float, ParamType::Enum})
        if (name == paramTypeName(type)) return type;
    fail(fmt::format("unknown parameter type '{}'", name));
    return ParamType::Bool;
}

} // namespace

PluginMetadata::PluginMetadata(const PenumbraPluginInfo& info, fs::path file, fs::path shaderDir)
    : file_(std::move(file)), abiVersion_(info.abiVersion), name_(info.name), version_(info.version),
      summary_(info.summary), shaderDir_(std::move(shaderDir))
{
    copyParams(info.params, info.paramCount);
}

void PluginMetadata::copyParams(const ParamSpec* specs, uint32_t count)
{
    auto strings = std::make_shared<Strings>();
    const auto keep = [&](const char* s) { return strings->text.emplace_back(s).c_str(); };
    for (uint32_t i = 0; i < count; ++i) {
        ParamSpec spec = specs[i];
        spec.name = keep(spec.name);
        spec.unit = keep(spec.unit);
        spec.doc = keep(spec.doc);
        if (spec.type == ParamType::Enum) {
            std::vector<const char*>& choices = strings->choiceLists.emplace_back();
            for (uint32_t c = 0; c < spec.choiceCount; ++c) choices.push_back(keep(spec.choices[c]));
            spec.choices = choices.data();
        } else {
            spec.choices = nullptr;
            spec.choiceCount = 0;
        }
        params_.push_back(spec);
    }
    strings_ = std::move(strings);
}

json PluginMetadata::toJson() const
{
    json params = json::array();
    for (const ParamSpec& spec : params_) params.push_back(specToJson(spec));
    return {{"name", name_},           {"version", version_}, {"summary", summary_},
            {"file", file_.string()},  {"abi", abiVersion_},  {"shader_dir", shaderDir_.string()},
            {"params", std::move(params)}};
}

PluginMetadata PluginMetadata::fromJson(const json& doc, const fs::path& file)
{
    const std::function<void(std::string)> fail = [&](const std::string& what) {
        throw PluginError(PluginErrorKind::InvalidInfo,
                          fmt::format("{}: the plugin's description from the plugin scanner is unreadable: {}", file.string(), what),
                          file);
    };
    const auto text = [&](const json& object, const char* key) -> std::string {
        if (!object.is_object() || !object.contains(key) || !object[key].is_string()) fail(fmt::format("'{}' is not a string", key));
        return object[key].get<std::string>();
    };
    const auto number = [&](const json& object, const char* key) -> double {
        if (!object.contains(key) || !object[key].is_number()) fail(fmt::format("'{}' is not a number", key));
        return object[key].get<double>();
    };
    const std::string name = text(doc, "name"), version = text(doc, "version"), summary = text(doc, "summary");
    const std::string shaderDir = text(doc, "shader_dir");
    if (!doc.contains("abi") || !doc["abi"].is_number_unsigned()) fail("'abi' is not a version number");
    if (!doc.contains("params") || !doc["params"].is_array()) fail("'params' is not an array");

    // The specs point into these until the metadata copies them.
    std::deque<std::string> strings;
    std::deque<std::vector<const char*>> choiceLists;
    std::vector<ParamSpec> specs;
    for (const json& p : doc["params"]) {
        ParamSpec spec{};
        spec.name = strings.emplace_back(text(p, "name")).c_str();
        spec.type = paramTypeNamed(text(p, "type"), fail);
        spec.unit = strings.emplace_back(text(p, "unit")).c_str();
        spec.doc = strings.emplace_back(text(p, "doc")).c_str();
        const json& defaultValue = p.contains("default") ? p["default"] : json();
        switch (spec.type) {
        case ParamType::Bool:
            if (!defaultValue.is_boolean()) fail(fmt::format("parameter '{}': the default is not true or false", spec.name));
            spec.defaultValue = defaultValue.get<bool>() ? 1.0 : 0.0;
            break;
        case ParamType::Int:
        case ParamType::Float:
            spec.defaultValue = number(p, "default");
            spec.minValue = number(p, "min");
            spec.maxValue = number(p, "max");
            if (p.contains("odd")) {
                if (!p["odd"].is_boolean()) fail(fmt::format("parameter '{}': 'odd' is not true or false", spec.name));
                spec.odd = p["odd"].get<bool>();
            }
            break;
        case ParamType::Enum: {
            if (!p.contains("choices") || !p["choices"].is_array()) fail(fmt::format("parameter '{}': no choices", spec.name));
            std::vector<const char*>& choices = choiceLists.emplace_back();
            for (const json& c : p["choices"]) {
                if (!c.is_string()) fail(fmt::format("parameter '{}': a choice is not a string", spec.name));
                choices.push_back(strings.emplace_back(c.get<std::string>()).c_str());
            }
            spec.choices = choices.data();
            spec.choiceCount = uint32_t(choices.size());
            const std::string chosen = text(p, "default");
            spec.defaultValue = double(choices.size());  // no choice: checkPluginInfo names it
            for (size_t c = 0; c < choices.size(); ++c)
                if (chosen == choices[c]) spec.defaultValue = double(c);
            break;
        }
        }
        specs.push_back(spec);
    }
    const PenumbraPluginInfo info{doc["abi"].get<uint32_t>(), name.c_str(), version.c_str(), summary.c_str(), specs.data(),
                                  uint32_t(specs.size()), &metadataHasNoFactory, nullptr};
    checkPluginInfo(info, file);
    return PluginMetadata(info, file, shaderDir);
}

} // namespace penumbra::plugin
