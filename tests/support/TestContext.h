#pragma once
// A Vulkan context for tests: validation layer on (with synchronization validation), and
// a check at the end of each test that it reported nothing.
#include "penumbra/gpu/Context.h"
#include "penumbra/plugin/PluginRegistry.h"

#include <gtest/gtest.h>

#include <memory>

namespace penumbra::test {

// The device tests run on: PENUMBRA_DEVICE if set, else the engine's default choice
// (lavapipe on the CI machine).
std::unique_ptr<gpu::Context> makeValidatedContext();

// The plugins of the build tree (and $PENUMBRA_PLUGIN_PATH), shared by every test in
// the process: libraries stay loaded until exit, after every renderer is gone.
plugin::PluginRegistry& plugins();

// Fails the current test if the layer reported any warning or error, printing them.
void expectNoValidationMessages(const gpu::Context& context);

class GpuTest : public ::testing::Test {
protected:
    void SetUp() override { context = makeValidatedContext(); }
    // Also destroys the context here, so that objects a test left alive (reported by the
    // layer at vkDestroyDevice) fail the test that leaked them.
    void TearDown() override
    {
        if (!context) return;
        expectNoValidationMessages(*context);
        const uint64_t before = gpu::validationMessagesInProcess();
        context.reset();
        EXPECT_EQ(gpu::validationMessagesInProcess(), before)
            << "the validation layer reported objects still alive at vkDestroyDevice (see the log above)";
    }
    std::unique_ptr<gpu::Context> context;
};

} // namespace penumbra::test
