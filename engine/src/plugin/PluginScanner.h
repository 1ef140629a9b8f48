#pragma once
// Runs the plugin scanner (engine/scanner/) on one plugin file in a process of its own:
// posix_spawn without a shell, stdout and stderr read through pipes up to a bound, the
// child killed when it outlives the timeout. A plugin that crashes the loader, or whose
// constructors or entry crash, abort or hang, kills or stalls only the scanner.
#include "penumbra/plugin/PluginMetadata.h"

#include <chrono>
#include <filesystem>
#include <string>

namespace penumbra::plugin {

// What the scanner read. Throws PluginError: the kind and message the scanner reported
// (not-a-library, dependency-missing, ...), or ScanFailed naming `who` and what happened
// to the scanner (the signal it died of, its exit status and last words, the timeout, or
// that it could not be started).
PluginMetadata scanInChildProcess(const std::filesystem::path& scanner, const std::filesystem::path& file,
                                  const std::string& who, std::chrono::milliseconds timeout);

} // namespace penumbra::plugin
