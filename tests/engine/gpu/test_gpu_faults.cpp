// GPU faults a user meets on a real device (issue 20): out of memory on any allocation
// and a lost device, injected through the gpu module's fault hooks
// (gpu::Context::setFaultHooks). Each is a GpuError (the CLI's exit 1) that says what
// failed: the image or buffer, how many MiB, what to lower; the pass or passes the lost
// device was running. Nothing crashes, leaks (ASan) or leaves objects alive (validation).
#include "PluginFrame.h"
#include "TestConfigs.h"

#include "penumbra/core/Error.h"
#include "penumbra/gpu/Check.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <string>
#include <vector>

using namespace penumbra;

namespace {

class GpuFaults : public test::PluginGpuTest {
protected:
    static config::RenderConfig smallConfig(const std::string& technique, int resolution)
    {
        config::RenderConfig cfg = test::boxOnGroundConfig();
        cfg.width = 96;
        cfg.height = 64;
        test::setShadow(cfg.lights[0], technique, {{"resolution", resolution}});
        // Every frame submits every pass: the faults count submissions and passes.
        cfg.keepUnchanged = false;
        return cfg;
    }
    // The GpuError of rendering `cfg`, or a failure when it renders.
    std::string renderError(const config::RenderConfig& cfg)
    {
        try {
            render(cfg, test::boxOnGroundScene());
        } catch (const GpuError& e) {
            frame.reset();
            return e.what();
        }
        ADD_FAILURE() << "the frame rendered";
        return {};
    }
    std::string lostDeviceMessage(const config::RenderConfig& cfg, size_t k);
    size_t passesNamed(const std::string& what) const;
};

} // namespace

TEST_F(GpuFaults, OutOfMemoryNamesWhatWasAllocatedItsSizeAndWhatToLower)
{
    // Allocations from a few KiB up fail in turn: buffers, images, render graph memory
    // (shared slots and their own). Each message names what the hook refused, in MiB.
    for (const char* technique : {"hard", "pcss", "vsm"}) {
        const config::RenderConfig cfg = smallConfig(technique, 1024);
        for (VkDeviceSize limit : {VkDeviceSize(4) << 10, VkDeviceSize(256) << 10, VkDeviceSize(2) << 20}) {
            SCOPED_TRACE(fmt::format("{}, allocations of {} bytes and more fail", technique, limit));
            std::string refused;
            VkDeviceSize refusedBytes = 0;
            context->setFaultHooks({[&](VkDeviceSize bytes, std::string_view what) {
                                        if (bytes < limit || !refused.empty()) return VK_SUCCESS;
                                        refused = what;
                                        refusedBytes = bytes;
                                        return VK_ERROR_OUT_OF_DEVICE_MEMORY;
                                    },
                                    {}});
            const std::string what = renderError(cfg);
            context->setFaultHooks({});
            ASSERT_FALSE(refused.empty()) << "no allocation reached the limit";
            EXPECT_NE(what.find("out of device memory: " + refused + " needs "), std::string::npos) << what;
            EXPECT_NE(what.find(fmt::format("{:.1f} MiB ({} bytes)", double(refusedBytes) / (1 << 20), refusedBytes)),
                      std::string::npos)
                << what;
            EXPECT_NE(what.find("lower "), std::string::npos) << what;
            EXPECT_NE(what.find("VK_ERROR_OUT_OF_DEVICE_MEMORY"), std::string::npos) << what;
        }
    }
    // The context is whole afterwards: the same config renders.
    render(smallConfig("hard", 1024), test::boxOnGroundScene());
    EXPECT_EQ(frame->checkedVisibility().size(), size_t(96 * 64));
}

TEST_F(GpuFaults, ARenderGraphImageIsNamedWithItsSizeFormatAndPass)
{
    // The shadow map of a 4096² hard shadow (the point light's cube atlas: 3 x 2 faces of
    // D32) is the frame's largest allocation: refused, it is named with its texels,
    // format and the pass that writes it, and its size in MiB.
    const config::RenderConfig cfg = smallConfig("hard", 4096);
    VkDeviceSize refusedBytes = 0;
    context->setFaultHooks({[&](VkDeviceSize bytes, std::string_view) {
                                if (bytes < (VkDeviceSize(64) << 20)) return VK_SUCCESS;
                                refusedBytes = bytes;
                                return VK_ERROR_OUT_OF_DEVICE_MEMORY;
                            },
                            {}});
    const std::string what = renderError(cfg);
    context->setFaultHooks({});
    EXPECT_NE(what.find("render graph image 'light0.hard.shadow_map' (12288 x 8192 D32_SFLOAT, first used by pass "
                        "'light0.hard.shadow_map')"),
              std::string::npos)
        << what;
    EXPECT_GE(refusedBytes, VkDeviceSize(12288) * 8192 * 4);
    EXPECT_NE(what.find(fmt::format("needs {:.1f} MiB", double(refusedBytes) / (1 << 20))), std::string::npos) << what;
    EXPECT_NE(what.find("resolution"), std::string::npos) << what;
}

// The message of a device lost at the k-th render graph submission of a frame, after
// one frame rendered `cfg` (every lazily made object exists).
std::string GpuFaults::lostDeviceMessage(const config::RenderConfig& cfg, size_t k)
{
    render(cfg, test::boxOnGroundScene());
    size_t submissions = 0;
    context->setFaultHooks({{}, [&] { return submissions++ == k ? VK_ERROR_DEVICE_LOST : VK_SUCCESS; }});
    std::string what;
    try {
        frame->renderer.renderFrame();
    } catch (const gpu::VulkanError& e) {
        what = e.what();
        EXPECT_EQ(e.result(), VK_ERROR_DEVICE_LOST);
    }
    context->setFaultHooks({});
    EXPECT_FALSE(what.empty()) << "the frame finished";
    return what;
}

// The passes of the frame's graph that `what` names.
size_t GpuFaults::passesNamed(const std::string& what) const
{
    size_t named = 0;
    for (const auto& pass : frame->renderer.compiledGraph().passes) named += what.find("'" + pass.name + "'") != std::string::npos;
    return named;
}

TEST_F(GpuFaults, ALostDeviceNamesThePassesOfItsSubmission)
{
    // One submission per frame (and one per host pass): its passes are the suspects.
    const std::string what = lostDeviceMessage(smallConfig("pcss", 512), 0);
    EXPECT_NE(what.find("the device was lost in a submission of render graph passes"), std::string::npos) << what;
    EXPECT_GE(passesNamed(what), 2u) << what;
    EXPECT_NE(what.find("PENUMBRA_ISOLATE_PASSES=1"), std::string::npos) << what;
    EXPECT_NE(what.find("VK_ERROR_DEVICE_LOST"), std::string::npos) << what;
}

TEST_F(GpuFaults, IsolatedPassesNameTheOnePassThatLostTheDevice)
{
    // PENUMBRA_ISOLATE_PASSES=1: every pass is submitted alone, so the k-th submission is
    // the k-th pass, named alone; and the frame is the same as without isolation.
    ::setenv("PENUMBRA_ISOLATE_PASSES", "1", 1);
    frame.reset();
    context = test::makeValidatedContext();
    ::unsetenv("PENUMBRA_ISOLATE_PASSES");
    ASSERT_TRUE(context->isolatePasses());
    const config::RenderConfig cfg = smallConfig("pcss", 512);
    for (size_t k : {size_t(0), size_t(1), size_t(2)}) {
        SCOPED_TRACE(fmt::format("submission {}", k));
        const std::string what = lostDeviceMessage(cfg, k);
        EXPECT_NE(what.find("the device was lost running render graph pass '"), std::string::npos) << what;
        EXPECT_EQ(passesNamed(what), 1u) << what;
        EXPECT_NE(what.find(fmt::format("'{}'", frame->renderer.compiledGraph().passes[k].name)), std::string::npos)
            << what;
    }
    render(cfg, test::boxOnGroundScene());
    const std::vector<float> isolated = frame->checkedVisibility();
    frame.reset();
    context = test::makeValidatedContext();
    render(cfg, test::boxOnGroundScene());
    EXPECT_EQ(frame->checkedVisibility(), isolated);
}
