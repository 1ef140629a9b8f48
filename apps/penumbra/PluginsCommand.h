#pragma once
// `penumbra plugins`: every technique plugin on the search path with its reflected
// parameters, and every plugin file that fails to load with the reason.
#include "CommandLine.h"

namespace penumbra::app {

// Exit 0 when the listing succeeds, even if it lists files that fail to load (--strict:
// exit 1 then).
Command addPluginsCommand(CLI::App& app);

} // namespace penumbra::app
