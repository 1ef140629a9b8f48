#pragma once
// `penumbra devices`: the Vulkan devices the loader reports, with API and driver version.
#include "CommandLine.h"

namespace penumbra::app {

Command addDevicesCommand(CLI::App& app);

} // namespace penumbra::app
