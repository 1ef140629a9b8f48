#include "DevicesCommand.h"

#include <fmt/format.h>

#include <cstdio>

namespace penumbra::app {
namespace {

int runDevices()
{
    const auto devices = gpu::Context::listDevices();
    if (devices.empty()) {
        fmt::print(stderr, "penumbra: no Vulkan device found (install mesa-vulkan-drivers for lavapipe)\n");
        return 1;
    }
    for (const auto& d : devices) {
        fmt::print("{} ({}), Vulkan {}.{}.{}, {}\n", d.name, d.type, VK_API_VERSION_MAJOR(d.apiVersion),
                   VK_API_VERSION_MINOR(d.apiVersion), VK_API_VERSION_PATCH(d.apiVersion), d.driverInfo);
    }
    return 0;
}

} // namespace

Command addDevicesCommand(CLI::App& app)
{
    return {app.add_subcommand("devices", "List the Vulkan devices the loader reports"), runDevices};
}

} // namespace penumbra::app
