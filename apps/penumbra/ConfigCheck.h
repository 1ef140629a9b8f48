#pragma once
// What `validate` and `bench` find wrong with a config before anything renders: for the
// config itself and each sweep variant, its run prepared (scene, lights, --set), each
// light's plugin loaded and its parameters checked; and every --set used by some variant.
// A light whose plugin fails to load is a warning (it renders unshadowed) unless its
// technique is required; a bad parameter value is always an error (the config's fault).
// Each distinct message is kept once, with the variants it was found in, so that one bad
// swept value reads as one error however many variants it is in.
#include "penumbra/config/Run.h"
#include "penumbra/config/Sweep.h"
#include "penumbra/plugin/PluginRegistry.h"

#include <cstddef>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

namespace penumbra::app {

class ConfigCheck {
public:
    struct Finding {
        std::string message;
        bool inConfig = false;         // found in the config itself (its base run)
        std::vector<size_t> variants;  // the sweep variants it was found in, ascending
    };

    ConfigCheck(const config::RunOptions& options, plugin::PluginRegistry& registry, size_t variantCount)
        : options_(options), registry_(registry), variantCount_(variantCount)
    {
    }

    // The config's own (base) run, prepared already; with `print`, one line per light with
    // the values its technique would get.
    void checkConfig(const config::RenderConfig& config, bool print);
    // Sweep variant `index`: made (only while it is checked: a variant is a copy of the
    // document), its run prepared (a ConfigError is one of its errors) and its plugins checked.
    void checkVariant(const config::SweepVariants& variants, size_t index);
    // After the last variant: every --set that no variant's lights use is an error.
    void checkOverridesUsed();

    const std::vector<Finding>& warnings() const { return warnings_.list; }
    const std::vector<Finding>& errors() const { return errors_.list; }
    // The message, and where it was found unless in the config itself: "... (in variants
    // 4, 5 of 6)", "... (in every variant)".
    std::string describe(const Finding& finding) const;

private:
    void checkPlugins(const config::RenderConfig& config, std::optional<size_t> variant, bool print);
    // Findings in the order found, and each message's place among them: a sweep of 100,000
    // variants may find as many distinct messages, each looked up once.
    struct Findings {
        std::vector<Finding> list;
        std::unordered_map<std::string, size_t> index;
    };
    static void add(Findings& findings, std::string message, std::optional<size_t> variant);

    const config::RunOptions& options_;
    plugin::PluginRegistry& registry_;
    size_t variantCount_;
    std::vector<std::string> usedOverrides_;  // ParamOverride::where of those some variant used
    Findings warnings_;
    Findings errors_;
};

} // namespace penumbra::app
