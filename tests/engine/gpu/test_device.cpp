#include "TestContext.h"

#include "penumbra/core/Error.h"
#include "penumbra/gpu/Context.h"
#include "penumbra/gpu/Resources.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <optional>
#include <string>

using namespace penumbra;

TEST(Device, CreatesOnLavapipeWithValidation)
{
    gpu::ContextOptions options;
    options.device.nameContains = "llvmpipe";
    options.validation = true;
    gpu::Context context(options);
    EXPECT_NE(context.device(), VK_NULL_HANDLE);
    EXPECT_NE(context.queue(), VK_NULL_HANDLE);
    EXPECT_EQ(context.deviceInfo().type, "cpu");
    EXPECT_GE(context.deviceInfo().apiVersion, VK_API_VERSION_1_3);
    EXPECT_NE(context.deviceInfo().name.find("llvmpipe"), std::string::npos);
    test::expectNoValidationMessages(context);
}

TEST(Device, SelectsByTypeCaseInsensitiveName)
{
    gpu::ContextOptions options;
    options.device.nameContains = "LLVMPIPE";
    options.device.type = "cpu";
    gpu::Context context(options);
    EXPECT_EQ(context.deviceInfo().type, "cpu");
}

TEST(Device, UnknownNameListsAvailableDevices)
{
    gpu::ContextOptions options;
    options.device.nameContains = "no-such-gpu-9000";
    try {
        gpu::Context context(options);
        FAIL() << "expected GpuError";
    } catch (const GpuError& e) {
        const std::string what = e.what();
        EXPECT_NE(what.find("no-such-gpu-9000"), std::string::npos) << what;
        EXPECT_NE(what.find("available"), std::string::npos) << what;
        EXPECT_NE(what.find("llvmpipe"), std::string::npos) << what;
    }
}

TEST(Device, UnknownTypeIsRejected)
{
    gpu::ContextOptions options;
    options.device.type = "quantum";
    EXPECT_THROW(gpu::Context{options}, GpuError);
}

TEST(Device, ListsLavapipe)
{
    const auto devices = gpu::Context::listDevices();
    ASSERT_FALSE(devices.empty());
    bool found = false;
    for (const auto& d : devices) found |= d.name.find("llvmpipe") != std::string::npos;
    EXPECT_TRUE(found);
}

TEST(Device, EnvironmentSetsTheSubmissionTimeoutOrNamesTheVariable)
{
    // The sanitizer presets set it; restore whatever the run had.
    const char* before = std::getenv("PENUMBRA_GPU_TIMEOUT_S");
    const std::optional<std::string> saved = before ? std::optional<std::string>(before) : std::nullopt;
    setenv("PENUMBRA_GPU_TIMEOUT_S", "120.5", 1);
    EXPECT_EQ(gpu::contextOptionsFromEnvironment({}).submitTimeoutSeconds, 120.5);
    for (const char* bad : {"0", "-1", "abc", "5s", "1e7", "nan", "inf"}) {
        setenv("PENUMBRA_GPU_TIMEOUT_S", bad, 1);
        try {
            gpu::contextOptionsFromEnvironment({});
            ADD_FAILURE() << bad << " was accepted";
        } catch (const ConfigError& e) {
            EXPECT_NE(std::string(e.what()).find("PENUMBRA_GPU_TIMEOUT_S: must be a number of seconds in (0, 1e6]"),
                      std::string::npos)
                << e.what();
        }
    }
    unsetenv("PENUMBRA_GPU_TIMEOUT_S");
    EXPECT_EQ(gpu::contextOptionsFromEnvironment({}).submitTimeoutSeconds, 60.0) << "the default";
    if (saved) setenv("PENUMBRA_GPU_TIMEOUT_S", saved->c_str(), 1);
}

TEST(Device, EnvironmentPicksDevice)
{
    setenv("PENUMBRA_DEVICE", "type:cpu", 1);
    const gpu::ContextOptions options = gpu::contextOptionsFromEnvironment({});
    unsetenv("PENUMBRA_DEVICE");
    EXPECT_EQ(options.device.type, "cpu");
    EXPECT_TRUE(options.device.nameContains.empty());
}

// A window's context (the viewer): the window system's instance extensions, a queue that
// presents, VK_KHR_swapchain. Without a display the window system's own test is replaced
// by one that says which families present.
TEST(Device, PresentationEnablesTheSurfaceExtensionsAndAQueueThatPresents)
{
    gpu::ContextOptions options;
    options.device.nameContains = "llvmpipe";
    options.validation = true;
    uint32_t asked = 0;
    options.presentation = gpu::Presentation{{"VK_KHR_surface"}, [&](VkInstance instance, VkPhysicalDevice, uint32_t) {
                                                  EXPECT_NE(instance, VK_NULL_HANDLE);
                                                  ++asked;
                                                  return true;
                                              }};
    gpu::Context context(options);
    EXPECT_TRUE(context.presents());
    EXPECT_GE(asked, 1u);
    // The swapchain's entry points exist only where the extension is enabled.
    EXPECT_NE(vkGetDeviceProcAddr(context.device(), "vkCreateSwapchainKHR"), nullptr);
    EXPECT_NE(vkGetInstanceProcAddr(context.instance(), "vkDestroySurfaceKHR"), nullptr);
    test::expectNoValidationMessages(context);

    gpu::ContextOptions headless;
    headless.device.nameContains = "llvmpipe";
    gpu::Context plain(headless);
    EXPECT_FALSE(plain.presents());
    EXPECT_EQ(vkGetDeviceProcAddr(plain.device(), "vkCreateSwapchainKHR"), nullptr);
}

TEST(Device, PresentationThatNoQueueOrLoaderCanGiveIsAClearError)
{
    gpu::ContextOptions options;
    options.device.nameContains = "llvmpipe";
    options.presentation = gpu::Presentation{{"VK_KHR_surface"}, [](VkInstance, VkPhysicalDevice, uint32_t) { return false; }};
    try {
        gpu::Context context(options);
        FAIL() << "a device whose queues cannot present was taken";
    } catch (const GpuError& e) {
        EXPECT_NE(std::string(e.what()).find("that can present to the window"), std::string::npos) << e.what();
    }
    options.presentation = gpu::Presentation{{"VK_KHR_no_such_surface"}, [](VkInstance, VkPhysicalDevice, uint32_t) { return true; }};
    try {
        gpu::Context context(options);
        FAIL() << "a missing instance extension was accepted";
    } catch (const GpuError& e) {
        EXPECT_NE(std::string(e.what()).find("VK_KHR_no_such_surface"), std::string::npos) << e.what();
    }
}

// An image only copied to and from (the viewer's uploaded debug image) has no view: Vulkan
// forbids one (VUID-VkImageViewCreateInfo-image-04441), so the validation layer stays quiet.
TEST(Device, ATransferOnlyImageHasNoViewAndOthersHaveOne)
{
    gpu::ContextOptions options;
    options.device.nameContains = "llvmpipe";
    options.validation = true;
    gpu::Context context(options);
    gpu::ImageDesc desc;
    desc.width = 4;
    desc.height = 2;
    desc.usage = VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
    desc.name = "copies only";
    const gpu::Image copies(context, desc);
    EXPECT_NE(copies.handle(), VK_NULL_HANDLE);
    EXPECT_EQ(copies.view(), VK_NULL_HANDLE);
    desc.usage |= VK_IMAGE_USAGE_SAMPLED_BIT;
    desc.name = "sampled";
    const gpu::Image sampled(context, desc);
    EXPECT_NE(sampled.view(), VK_NULL_HANDLE);
    test::expectNoValidationMessages(context);
}
