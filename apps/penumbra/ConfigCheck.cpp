#include "ConfigCheck.h"

#include "penumbra/core/Error.h"
#include "penumbra/plugin/Params.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>

using nlohmann::json;

namespace penumbra::app {

void ConfigCheck::add(Findings& findings, std::string message, std::optional<size_t> variant)
{
    const auto [at, added] = findings.index.emplace(message, findings.list.size());
    if (added) findings.list.push_back(Finding{std::move(message), false, {}});
    Finding& found = findings.list[at->second];
    if (!variant) found.inConfig = true;
    else if (found.variants.empty() || found.variants.back() != *variant) found.variants.push_back(*variant);
}

void ConfigCheck::checkConfig(const config::RenderConfig& config, bool print) { checkPlugins(config, std::nullopt, print); }

void ConfigCheck::checkVariant(const config::SweepVariants& variants, size_t index)
{
    try {
        const config::PreparedRun run = config::prepareRun(variants.variant(index).config, options_);
        for (const config::ParamOverride& o : config::overridesUsedBy(options_.overrides, run.config)) {
            usedOverrides_.push_back(o.where);
        }
        checkPlugins(run.config, index, false);
    } catch (const ConfigError& e) {
        add(errors_, e.what(), index);
    }
}

void ConfigCheck::checkOverridesUsed()
{
    for (const config::ParamOverride& o : options_.overrides) {
        if (std::find(usedOverrides_.begin(), usedOverrides_.end(), o.where) != usedOverrides_.end()) continue;
        add(errors_, fmt::format("{}: no light of any sweep variant uses technique '{}'", o.where, o.technique),
            std::nullopt);
    }
}

void ConfigCheck::checkPlugins(const config::RenderConfig& config, std::optional<size_t> variant, bool print)
{
    for (size_t i = 0; i < config.lights.size(); ++i) {
        const config::LightConfig& light = config.lights[i];
        const std::string who = fmt::format("light {} ('{}')", i, light.name);
        if (light.shadow.unshadowed()) {  // no plugin: nothing to load or check
            if (print) fmt::print("{}: unshadowed (technique \"{}\")\n", who, light.shadow.technique);
            continue;
        }
        // Scanned, not loaded: checking a config runs no plugin code in this process.
        const plugin::PluginMetadata* scanned = nullptr;
        try {
            scanned = &registry_.scan(light.shadow.technique);
        } catch (const plugin::PluginError& e) {
            // As render decides (frame/FrameRenderer.cpp). A misspelt technique ("pcsss") is
            // FileMissing, whose message lists the plugins found and the closest name.
            if (light.shadow.loadFailureStopsTheRun()) {
                add(errors_,
                    fmt::format("{}{}: {}technique '{}' cannot be used: {}{}",
                                light.shadow.techniqueWhere.empty() ? "" : light.shadow.techniqueWhere + ": ", who,
                                light.shadow.required ? "required " : "", light.shadow.technique, e.what(),
                                light.shadow.required ? "" : config::kOptionalTechniqueHint),
                    variant);
            } else {
                add(warnings_, fmt::format("{} would render without shadows: {}", who, e.what()), variant);
            }
            continue;
        }
        std::vector<std::string> badValues;
        const plugin::ParamValues values = plugin::resolveParams(*scanned, light.shadow, &badValues);
        for (std::string& message : badValues) add(errors_, std::move(message), variant);
        if (print && badValues.empty()) {
            const json current = values.toJson();
            std::vector<std::string> settings;
            for (const plugin::ParamSpec& spec : values.specs()) {
                settings.push_back(fmt::format("{}={}", spec.name, current[spec.name].dump()));
            }
            fmt::print("{}: plugin {} {} ({}): {}\n", who, scanned->name(), scanned->version(), scanned->file().string(),
                       settings.empty() ? "no parameters" : fmt::format("{}", fmt::join(settings, " ")));
        }
    }
}

std::string ConfigCheck::describe(const Finding& finding) const
{
    if (finding.inConfig || finding.variants.empty() || variantCount_ < 2) return finding.message;
    if (finding.variants.size() == variantCount_) return finding.message + " (in every variant)";
    std::vector<size_t> numbers;  // as the variants are listed: from 1
    for (const size_t v : finding.variants) numbers.push_back(v + 1);
    return fmt::format("{} (in variant{} {} of {})", finding.message, numbers.size() > 1 ? "s" : "",
                       fmt::join(numbers, ", "), variantCount_);
}

} // namespace penumbra::app
