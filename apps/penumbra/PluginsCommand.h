#pragma once
// `penumbra plugins`: every technique plugin on the search path with its reflected
// parameters, and every plugin file that fails to load with the reason; and the plugin
// half of `penumbra validate`: each light's plugin loaded and its parameters checked.
#include "CommandLine.h"
#include "penumbra/config/RenderConfig.h"
#include "penumbra/plugin/PluginRegistry.h"

#include <string>
#include <vector>

namespace penumbra::app {

// Exit 0 when the listing succeeds, even if it lists files that fail to load (--strict:
// exit 1 then).
Command addPluginsCommand(CLI::App& app);

// What validating a config's plugins found. A light whose plugin fails to load is a
// warning (it renders unshadowed) unless its technique is required; a bad parameter value
// is always an error (the config's fault). Each message once, in the order found.
class PluginCheck {
public:
    // Loads each light's plugin and resolves its parameters; with `print`, one line per
    // light with the values its technique would get.
    void check(const config::RenderConfig& config, plugin::PluginRegistry& registry, bool print);

    const std::vector<std::string>& warnings() const { return warnings_; }
    const std::vector<std::string>& errors() const { return errors_; }

private:
    static void addOnce(std::vector<std::string>& list, std::string message);
    std::vector<std::string> warnings_;
    std::vector<std::string> errors_;
};

} // namespace penumbra::app
