// Choosing the Vulkan device: `penumbra devices`, --device, --device-type and
// PENUMBRA_DEVICE, and a machine without a Vulkan driver.
#include "CliTest.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

using namespace penumbra::test;
namespace fs = std::filesystem;

TEST_F(Cli, UnknownDeviceNameListsDevices)
{
    const CliResult r = run(fmt::format("render {} -o '{}/out.png' --device no-such-gpu", config("default.json"), dir.string()));
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("no suitable device"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("no-such-gpu"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("available:"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir / "out.png"));
}

TEST_F(Cli, UnknownDeviceFromEnvironment)
{
    const CliResult r = run(fmt::format("render {} -o '{}/out.png'", config("default.json"), dir.string()),
                      "PENUMBRA_DEVICE=no-such-gpu");
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("no suitable device"), std::string::npos) << r.err;
}

TEST_F(Cli, NoVulkanDriver)
{
    // Point the loader at a driver manifest that does not exist: no ICD at all.
    const CliResult r = run(fmt::format("render {} -o '{}/out.png'", config("default.json"), dir.string()),
                      "VK_DRIVER_FILES=/nonexistent/icd.json VK_ICD_FILENAMES=/nonexistent/icd.json");
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("Vulkan"), std::string::npos) << r.err;
    EXPECT_TRUE(r.err.find("no Vulkan") != std::string::npos || r.err.find("driver") != std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir / "out.png"));
}

TEST_F(Cli, NoDeviceOfRequestedType)
{
    // The CI machine has only lavapipe (a CPU device): asking for a discrete GPU fails
    // with the list of what there is.
    const CliResult r = run(fmt::format("render {} -o '{}/out.png' --device-type discrete", config("default.json"), dir.string()),
                            "PENUMBRA_DEVICE=");
    if (r.exitCode == 0) GTEST_SKIP() << "this machine has a discrete GPU";
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("no suitable device: wanted a device of type 'discrete'"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir / "out.png"));
}

TEST_F(Cli, ListsDevices)
{
    const CliResult r = run("devices");
    EXPECT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("Vulkan 1.3"), std::string::npos) << r.out;
}
