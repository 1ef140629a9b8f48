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
    void TearDown() override
    {
        if (context) expectNoValidationMessages(*context);
    }
    std::unique_ptr<gpu::Context> context;
};

} // namespace penumbra::test
