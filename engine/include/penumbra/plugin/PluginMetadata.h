#pragma once
// What a plugin declares about itself (its PenumbraPluginInfo without the factory), as
// data the engine owns: the plugin scanner reads it in a process of its own and hands it
// over as JSON (PluginRegistry::scan), so that listing plugins and checking configs never
// run a plugin's code in the engine's process; the scan cache keeps it between runs.
#include "penumbra/plugin/Params.h"
#include "penumbra/plugin/Plugin.h"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace penumbra::plugin {

class PluginMetadata {
public:
    // Copies what `info` points at (after checkPluginInfo accepted it); `file` is the
    // plugin file, `shaderDir` its resolved shader folder (LoadedPlugin::shaderDir).
    PluginMetadata(const PenumbraPluginInfo& info, std::filesystem::path file, std::filesystem::path shaderDir);

    // The form `penumbra plugins --json` prints and the scanner writes: {name, version,
    // summary, file, abi, shader_dir, params: [specToJson...]}.
    nlohmann::json toJson() const;
    // Reads toJson()'s form back, checking it as checkPluginInfo checks an entry's info
    // (the scanner's output or a cache entry may be damaged). Throws PluginError
    // InvalidInfo naming `file` and what is wrong.
    static PluginMetadata fromJson(const nlohmann::json& doc, const std::filesystem::path& file);

    const std::filesystem::path& file() const { return file_; }
    uint32_t abiVersion() const { return abiVersion_; }
    const std::string& name() const { return name_; }
    const std::string& version() const { return version_; }
    const std::string& summary() const { return summary_; }
    const std::filesystem::path& shaderDir() const { return shaderDir_; }
    // The reflected parameters. Their strings are owned by this object and its copies:
    // ParamValues made from them must not outlive every copy.
    const std::vector<ParamSpec>& params() const { return params_; }
    ParamValues defaultParams() const { return ParamValues(name_, params_.data(), uint32_t(params_.size())); }

private:
    struct Strings;  // the text params_ points into, shared by copies
    PluginMetadata() = default;
    void copyParams(const ParamSpec* specs, uint32_t count);

    std::filesystem::path file_;
    uint32_t abiVersion_ = 0;
    std::string name_, version_, summary_;
    std::filesystem::path shaderDir_;
    std::shared_ptr<const Strings> strings_;
    std::vector<ParamSpec> params_;
};

} // namespace penumbra::plugin
