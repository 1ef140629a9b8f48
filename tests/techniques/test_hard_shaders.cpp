// The hard shadow plugin's GLSL (plugins/hard): every shader variant that a parameter
// set can select compiles, and the depth-compare sampler its bilinear filter relies on
// behaves as the plugin assumes on this device. These run without the plugin loaded:
// they need only the engine's shader compiler and a device.
#include "TestContext.h"
#include "TestPaths.h"  // support/: the build tree's paths

#include "penumbra/core/Error.h"
#include "penumbra/gpu/Context.h"
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/gpu/Resources.h"
#include "penumbra/gpu/ShaderCompiler.h"

#include "penumbra/plugin/VisibilityFunction.h"
#include "plugins/hard/visibility_pass.h"

#include <gtest/gtest.h>

#include <cstring>
#include <set>

using namespace penumbra;
namespace fs = std::filesystem;

namespace {

const fs::path kPluginDir = penumbra::test::sourceDir() / "plugins/hard";

// The search path the engine gives a plugin: its own folder first, then shaders/.
gpu::ShaderCompiler pluginCompiler() { return gpu::ShaderCompiler({kPluginDir, gpu::engineShaderDir()}); }

// The plugin's visibility pass (visibility.glsl in the SDK's pass), as the plugin compiles it.
std::vector<uint32_t> compileVisibility(const gpu::ShaderCompiler& compiler, const std::vector<gpu::ShaderDefine>& defines)
{
    const fs::path function = kPluginDir / "visibility.glsl";
    return compiler.compileSource(plugin::visibilityPassSource(function), kPluginDir / "visibility.glsl.pass.comp",
                                  VK_SHADER_STAGE_COMPUTE_BIT, defines);
}

// Every variant the plugin's parameters can select, each once.
std::vector<hard::VisibilityVariant> everyVisibilityVariant()
{
    std::vector<hard::VisibilityVariant> variants;
    std::set<std::vector<std::pair<std::string, std::string>>> seen;
    auto add = [&](const hard::VisibilityVariant& v) {
        std::vector<std::pair<std::string, std::string>> key;
        for (const gpu::ShaderDefine& d : hard::visibilityDefines(v)) key.emplace_back(d.name, d.value);
        if (seen.insert(key).second) variants.push_back(v);
    };
    for (uint32_t f = 0; f < std::size(hard::kFilterNames); ++f) {
        for (uint32_t b = 0; b < std::size(hard::kBiasModeNames); ++b) {
            hard::VisibilityVariant v{hard::Filter(f), hard::BiasMode(b)};
            for (int k = hard::kPcfKernelMin; k <= hard::kPcfKernelMax; k += 2) {
                v.pcfKernel = uint32_t(k);
                for (int s = hard::kPoissonSamplesMin; s <= hard::kPoissonSamplesMax; ++s) {
                    v.poissonSamples = uint32_t(s);
                    add(v);
                }
            }
        }
    }
    return variants;
}

} // namespace

TEST(HardShaders, EveryVisibilityVariantCompiles)
{
    const gpu::ShaderCompiler compiler = pluginCompiler();
    const std::vector<hard::VisibilityVariant> variants = everyVisibilityVariant();
    // Constant and slope bias share the compute variant (they live in the rasterizer):
    // 3 receiver-side modes x (none + 8 PCF kernels + 61 Poisson counts + bilinear).
    EXPECT_EQ(variants.size(), 3u * (1u + 8u + 61u + 1u));
    for (const hard::VisibilityVariant& v : variants) {
        std::string label;
        for (const gpu::ShaderDefine& d : hard::visibilityDefines(v)) label += d.name + "=" + d.value + " ";
        SCOPED_TRACE(label);
        const std::vector<uint32_t> spirv = compileVisibility(compiler, hard::visibilityDefines(v));
        ASSERT_GT(spirv.size(), 5u);
        EXPECT_EQ(spirv[0], 0x07230203u);
    }
}

TEST(HardShaders, CasterShadersCompileSolidAndMasked)
{
    // The depth pass is the engine's (render::ShadowMap), compiled through the plugin's
    // search path as the plugin's ShadowMap does.
    const gpu::ShaderCompiler compiler = pluginCompiler();
    EXPECT_NO_THROW(compiler.compile("engine/shadow_depth.vert"));
    EXPECT_NO_THROW(compiler.compile("engine/shadow_depth.vert", {{"ALPHA_MASK", "1"}}));
    EXPECT_NO_THROW(compiler.compile("engine/shadow_depth.frag", {{"ALPHA_MASK", "1"}}));
    // Depth peeling's (ShadowMap::addPeeledDepthPass), solid and masked.
    EXPECT_NO_THROW(compiler.compile("engine/shadow_depth.frag", {{"PEEL", "1"}}));
    EXPECT_NO_THROW(compiler.compile("engine/shadow_depth.frag", {{"PEEL", "1"}, {"ALPHA_MASK", "1"}}));
}

TEST(HardShaders, VariantWithoutItsDefinesIsAnError)
{
    const gpu::ShaderCompiler compiler = pluginCompiler();
    // Without defines it is the default variant (no filter, no receiver-side bias); a
    // filter without its own parameter define is an error.
    EXPECT_NO_THROW(compileVisibility(compiler, {}));
    EXPECT_THROW(compileVisibility(compiler, {{"FILTER", "1"}, {"RECEIVER_BIAS", "0"}}), ShaderCompileError);
}

TEST(HardShaders, OnlyTheDefinesAVariantReadsAreSet)
{
    // Two parameter sets that compile the same code ask for the same variant: the PCF
    // kernel does not matter without PCF, nor constant vs slope bias in the shader.
    hard::VisibilityVariant a{hard::Filter::None, hard::BiasMode::Constant, 3, 16};
    hard::VisibilityVariant b{hard::Filter::None, hard::BiasMode::Slope, 7, 32};
    auto names = [](const hard::VisibilityVariant& v) {
        std::vector<std::string> out;
        for (const gpu::ShaderDefine& d : hard::visibilityDefines(v)) out.push_back(d.name + "=" + d.value);
        return out;
    };
    EXPECT_EQ(names(a), names(b));
    b.filter = hard::Filter::Pcf;
    EXPECT_EQ(names(b), (std::vector<std::string>{"FILTER=1", "RECEIVER_BIAS=0", "PCF_KERNEL=7"}));
    b.bias = hard::BiasMode::ReceiverPlane;
    b.filter = hard::Filter::Bilinear;
    EXPECT_FALSE(b.hardwareBilinear());  // receiver plane compares the four texels by hand
}

namespace {

// Two texels of depth 0.2 and 0.8 side by side, read through a compare sampler with
// reference depth 0.5 (GREATER_OR_EQUAL, as the plugin's reversed-Z compare): the left
// texel passes, the right one fails.
class DepthCompareSampler : public test::GpuTest {
protected:
    std::vector<float> probe(VkFilter filter, const std::vector<glm::vec4>& points)
    {
        const float depth[2] = {0.2f, 0.8f};
        const gpu::Image map = gpu::uploadImage(*context, 2, 1, VK_FORMAT_D32_SFLOAT,
                                                std::as_bytes(std::span(depth)), "probe.depth");
        gpu::Buffer probes(*context, points.size() * sizeof(glm::vec4), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true,
                           "probe.points");
        std::memcpy(probes.mapped(), points.data(), points.size() * sizeof(glm::vec4));
        const gpu::ShaderCompiler compiler({penumbra::test::testDataDir() / "shaders", gpu::engineShaderDir()});
        gpu::ComputePipelineDesc desc;
        desc.name = "depth_compare_probe";
        desc.shader = "depth_compare_probe.comp";
        const gpu::Pipeline pipeline(*context, compiler, desc);
        const gpu::Sampler sampler = gpu::createSampler(*context, filter, VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE,
                                               VK_COMPARE_OP_GREATER_OR_EQUAL);
        context->submitAndWait([&](VkCommandBuffer cmd) {
            pipeline.bind(cmd);
            gpu::DescriptorPush().sampledImage("depthMap", map, sampler).storageBuffer("Probes", probes).push(*context, cmd, pipeline);
            pipeline.dispatchOver(cmd, uint32_t(points.size()));
        });
        std::vector<float> results;
        for (size_t i = 0; i < points.size(); ++i) results.push_back(static_cast<const glm::vec4*>(probes.mapped())[i].w);
        return results;
    }
};

} // namespace

TEST_F(DepthCompareSampler, LinearFilterWithCompareWeightsTheFourTexels)
{
    // D32 advertises no linear filtering on lavapipe, yet a LINEAR sampler with
    // compareEnable is legal and filters the four compare results (PLATFORM.md): the
    // plugin's `filter: bilinear` uses it. Texel centres are at u = 0.25 and 0.75.
    const std::vector<float> v = probe(VK_FILTER_LINEAR, {{0.25f, 0.5f, 0.5f, 0.0f},
                                                          {0.375f, 0.5f, 0.5f, 0.0f},
                                                          {0.5f, 0.5f, 0.5f, 0.0f},
                                                          {0.625f, 0.5f, 0.5f, 0.0f},
                                                          {0.75f, 0.5f, 0.5f, 0.0f}});
    const float expected[] = {1.0f, 0.75f, 0.5f, 0.25f, 0.0f};
    for (size_t i = 0; i < v.size(); ++i) EXPECT_NEAR(v[i], expected[i], 1.0f / 256.0f) << "probe " << i;
}

TEST_F(DepthCompareSampler, NearestFilterGivesOneCompare)
{
    const std::vector<float> v = probe(VK_FILTER_NEAREST, {{0.3f, 0.5f, 0.5f, 0.0f}, {0.7f, 0.5f, 0.5f, 0.0f}});
    EXPECT_EQ(v[0], 1.0f);
    EXPECT_EQ(v[1], 0.0f);
}
