// Pipelines as plugins use them: descriptor set layouts and workgroup sizes read from the
// shaders (gpu/ShaderInterface.h), descriptors bound by name, dispatches over a grid.
#include "ErrorText.h"
#include "TestContext.h"
#include "TestPaths.h"  // support/: the build tree's paths

#include "penumbra/core/Error.h"
#include "penumbra/gpu/Barrier.h"
#include "penumbra/gpu/Context.h"
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/gpu/Resources.h"
#include "penumbra/gpu/ShaderInterface.h"

#include <gtest/gtest.h>

#include <array>
#include <cstring>
#include <string>
#include <vector>

using namespace penumbra;
using test::errorOf;
namespace fs = std::filesystem;

namespace {

const fs::path kData = penumbra::test::testDataDir() / "shaders";

gpu::ShaderCompiler compiler() { return gpu::ShaderCompiler({kData, gpu::engineShaderDir()}); }

} // namespace

TEST(ShaderInterface, ReadsEveryBindingWithItsNameTypeAndCount)
{
    const std::vector<uint32_t> spirv = compiler().compile("interface_probe.comp");
    const gpu::ShaderInterface shader =
        gpu::reflectShaderInterface(spirv, VK_SHADER_STAGE_COMPUTE_BIT, "interface_probe.comp");
    EXPECT_EQ(shader.localSize, (std::array<uint32_t, 3>{32, 2, 1}));

    struct Expected {
        const char* name;
        const char* blockName;
        uint32_t binding;
        VkDescriptorType type;
        uint32_t count;
    };
    const Expected expected[] = {
        {"visibilityOut", "", 0, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1},
        {"maps", "", 2, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 3},
        {"shadowMapBuffer", "ShadowMapBuffer", 3, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1},
        {"Lights", "Lights", 4, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1},  // no instance name: the block's
        {"camera", "Camera", 5, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 1},
        {"unusedHere", "", 7, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1},  // declared, never read: still bound
    };
    ASSERT_EQ(shader.bindings.size(), std::size(expected));
    for (size_t i = 0; i < std::size(expected); ++i) {
        SCOPED_TRACE(expected[i].name);
        const gpu::ShaderBinding& b = shader.bindings[i];
        EXPECT_EQ(b.name, expected[i].name);
        EXPECT_EQ(b.blockName, expected[i].blockName);
        EXPECT_EQ(b.binding, expected[i].binding);
        EXPECT_EQ(b.type, expected[i].type);
        EXPECT_EQ(b.count, expected[i].count);
        EXPECT_EQ(b.stages, VkShaderStageFlags(VK_SHADER_STAGE_COMPUTE_BIT));
    }
    // A buffer answers to its instance name and to its block name.
    EXPECT_EQ(shader.find("ShadowMapBuffer"), &shader.bindings[2]);
    EXPECT_EQ(shader.find("shadowMapBuffer"), &shader.bindings[2]);
    EXPECT_EQ(shader.find("Camera"), &shader.bindings[4]);
    EXPECT_EQ(shader.find("nothing"), nullptr);
}

TEST(ShaderInterface, RefusesADescriptorSetOtherThanZero)
{
    const std::vector<uint32_t> spirv = compiler().compile("descriptor_set_one.comp");
    const std::string what = errorOf(
        [&] { gpu::reflectShaderInterface(spirv, VK_SHADER_STAGE_COMPUTE_BIT, "descriptor_set_one.comp"); });
    EXPECT_NE(what.find("descriptor_set_one.comp: 'visibilityOut' is in descriptor set 1"), std::string::npos) << what;
}

TEST(ShaderInterface, MergingStagesRefusesOneBindingOfTwoTypes)
{
    gpu::ShaderInterface vertex, fragment;
    vertex.bindings = {{"instances", "Instances", 0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_VERTEX_BIT}};
    fragment.bindings = {{"albedo", "", 0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_FRAGMENT_BIT}};
    const std::string what = errorOf([&] { vertex.merge(fragment, "light0.mine.depth"); });
    EXPECT_NE(what.find("light0.mine.depth: binding 0 is declared as 'instances'"), std::string::npos) << what;
    EXPECT_NE(what.find("'albedo'"), std::string::npos) << what;

    // The same binding in both stages, of one type: one binding seen by both.
    fragment.bindings = {{"instances", "Instances", 0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_FRAGMENT_BIT}};
    vertex.merge(fragment, "light0.mine.depth");
    ASSERT_EQ(vertex.bindings.size(), 1u);
    EXPECT_EQ(vertex.bindings[0].stages, VkShaderStageFlags(VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT));
}

class PipelineTest : public test::GpuTest {};

// dispatchOver with the shader's own local size (16 x 4) covers every cell of grids that
// are and are not multiples of it exactly once, and dispatches no workgroup beyond the
// last one a cell needs.
TEST_F(PipelineTest, DispatchOverCoversAGridExactlyOnce)
{
    const gpu::Pipeline count(*context, compiler(),
                              gpu::ComputePipelineDesc{"dispatch count", "dispatch_count.comp", {}, 8});
    EXPECT_EQ(count.shaderInterface().localSize, (std::array<uint32_t, 3>{16, 4, 1}));
    const std::array<uint32_t, 2> grids[] = {{37, 11}, {16, 4}, {1, 1}, {129, 3}};
    for (const auto& [width, height] : grids) {
        SCOPED_TRACE(std::to_string(width) + " x " + std::to_string(height));
        gpu::Buffer hits(*context, VkDeviceSize(width) * height * sizeof(uint32_t), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                         true, "hits");
        gpu::Buffer overhang(*context, sizeof(uint32_t), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true, "overhang");
        std::memset(hits.mapped(), 0, hits.size());
        std::memset(overhang.mapped(), 0, overhang.size());
        context->submitAndWait([&](VkCommandBuffer cmd) {
            count.bind(cmd);
            gpu::DescriptorPush().storageBuffer("Hits", hits).storageBuffer("Overhang", overhang).push(*context, cmd, count);
            const std::array<uint32_t, 2> size{width, height};
            count.pushConstants(cmd, size.data(), sizeof(size));
            count.dispatchOver(cmd, width, height);
            gpu::memoryBarrier(cmd, {VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT},
                               {VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT});
        });
        std::vector<uint32_t> perCell(size_t(width) * height);
        std::memcpy(perCell.data(), hits.mapped(), hits.size());
        for (size_t i = 0; i < perCell.size(); ++i) ASSERT_EQ(perCell[i], 1u) << "cell " << i;
        uint32_t outside = 0;
        std::memcpy(&outside, overhang.mapped(), sizeof outside);
        const uint32_t coveredWidth = (width + 15) / 16 * 16, coveredHeight = (height + 3) / 4 * 4;
        EXPECT_EQ(outside, coveredWidth * coveredHeight - width * height);
    }
}

TEST_F(PipelineTest, AnUnknownBindingNameNamesThePipelineAndTheBinding)
{
    const gpu::Pipeline count(*context, compiler(),
                              gpu::ComputePipelineDesc{"light3.mine.count", "dispatch_count.comp", {}, 8});
    const std::string what = errorOf([&] { count.binding("Hit"); });
    EXPECT_NE(what.find("pipeline 'light3.mine.count': its shaders declare no binding 'Hit' (did you mean 'Hits'?)"),
              std::string::npos)
        << what;
    EXPECT_NE(what.find("they declare: Hits, Overhang"), std::string::npos) << what;

    // Pushed by name: the same error, before anything is recorded.
    gpu::Buffer buffer(*context, 16, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT, true, "b");
    const std::string pushed = errorOf([&] {
        context->submitAndWait(
            [&](VkCommandBuffer cmd) { gpu::DescriptorPush().storageBuffer("hits", buffer).push(*context, cmd, count); });
    });
    EXPECT_NE(pushed.find("pipeline 'light3.mine.count': its shaders declare no binding 'hits'"), std::string::npos)
        << pushed;
}

TEST_F(PipelineTest, ADescriptorOfAnotherTypeThanTheShadersNamesBoth)
{
    const gpu::Pipeline count(*context, compiler(),
                              gpu::ComputePipelineDesc{"light3.mine.count", "dispatch_count.comp", {}, 8});
    gpu::Buffer buffer(*context, 16, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT, true, "b");
    const std::string what = errorOf([&] {
        context->submitAndWait(
            [&](VkCommandBuffer cmd) { gpu::DescriptorPush().uniformBuffer("Hits", buffer).push(*context, cmd, count); });
    });
    EXPECT_NE(what.find("pipeline 'light3.mine.count': binding 'Hits' is a storage buffer in its shaders, set here as "
                        "a uniform buffer"),
              std::string::npos)
        << what;
}

// A graphics pipeline's layout is the union of its stages' bindings, each visible to the
// stages that declare it (the engine's alpha-tested shadow depth pass).
TEST_F(PipelineTest, GraphicsLayoutJoinsTheStagesBindings)
{
    gpu::GraphicsPipelineDesc d;
    d.name = "masked depth";
    d.vertexShader = "engine/shadow_depth.vert";
    d.fragmentShader = "engine/shadow_depth.frag";
    d.defines = {{"ALPHA_MASK", "1"}};
    d.pushConstantBytes = 64;
    d.vertexLayout = {20, {{0, 0, VK_FORMAT_R32G32B32_SFLOAT, 0}, {2, 0, VK_FORMAT_R32G32_SFLOAT, 12}}};
    d.depthFormat = VK_FORMAT_D32_SFLOAT;
    const gpu::Pipeline masked(*context, compiler(), d);
    const std::vector<gpu::ShaderBinding>& bindings = masked.shaderInterface().bindings;
    ASSERT_EQ(bindings.size(), 3u);
    EXPECT_EQ(bindings[0].name, "Instances");
    EXPECT_EQ(bindings[0].stages, VkShaderStageFlags(VK_SHADER_STAGE_VERTEX_BIT));
    EXPECT_EQ(bindings[1].name, "Materials");
    EXPECT_EQ(bindings[1].stages, VkShaderStageFlags(VK_SHADER_STAGE_FRAGMENT_BIT));
    EXPECT_EQ(bindings[2].name, "baseColorTexture");
    EXPECT_EQ(bindings[2].type, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER);
    EXPECT_EQ(masked.shaderInterface().localSize, (std::array<uint32_t, 3>{0, 0, 0}));
    const std::string what = errorOf([&] { masked.dispatchOver(VK_NULL_HANDLE, 8, 8); });
    EXPECT_NE(what.find("pipeline 'masked depth': dispatchOver needs a compute pipeline"), std::string::npos) << what;
}
