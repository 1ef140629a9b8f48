// The render graph executor on the device, under the validation layer with
// synchronization validation (any message fails the test): culled passes never run,
// compute and transfer chains produce the right numbers, aliased transients never
// overwrite live data (also on random graphs checked against a CPU simulation), imported
// images return to their declared layout, frames reuse transients, and misuse errors
// name the pass and the resource.
//
// Tests that check the graph's own barriers turn GPU timestamps off: the timer's
// execution barrier after every start timestamp would order each pass after all earlier
// ones and so hide a missing write-after-read dependency from synchronization validation.
#include "ErrorText.h"
#include "RandomGraph.h"
#include "TestContext.h"
#include "TestPaths.h"  // support/: the build tree's paths

#include "penumbra/core/Error.h"
#include "penumbra/gpu/Barrier.h"
#include "penumbra/gpu/Context.h"
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/gpu/Resources.h"
#include "penumbra/graph/GraphExecutor.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <functional>
#include <map>
#include <random>
#include <span>
#include <thread>

using namespace penumbra;
using test::errorOf;
using namespace penumbra::graph;

namespace {

const std::filesystem::path kShaders = penumbra::test::testDataDir() / "shaders";

constexpr ExecutorOptions kNoTimestamps{false};

// Copies a whole buffer (device-local or not) into host memory after everything
// submitted before it.
std::vector<uint32_t> readWords(gpu::Context& context, const gpu::Buffer& buffer)
{
    gpu::Buffer staging(context, buffer.size(), VK_BUFFER_USAGE_TRANSFER_DST_BIT, true, "read-back");
    context.submitAndWait([&](VkCommandBuffer cmd) {
        gpu::memoryBarrier(cmd, {VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_WRITE_BIT},
                           {VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_READ_BIT});
        const VkBufferCopy region{0, 0, buffer.size()};
        vkCmdCopyBuffer(cmd, buffer.handle(), staging.handle(), 1, &region);
        gpu::memoryBarrier(cmd, {VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT},
                           {VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT});
    });
    std::vector<uint32_t> words(buffer.size() / sizeof(uint32_t));
    std::memcpy(words.data(), staging.mapped(), words.size() * sizeof(uint32_t));
    return words;
}

std::vector<float> readFloats(gpu::Context& context, const gpu::Buffer& buffer)
{
    const std::vector<uint32_t> words = readWords(context, buffer);
    std::vector<float> out(words.size());
    std::memcpy(out.data(), words.data(), words.size() * sizeof(float));
    return out;
}

bool allEqual(const std::vector<uint32_t>& words, size_t begin, size_t end, uint32_t value)
{
    return std::all_of(words.begin() + ptrdiff_t(begin), words.begin() + ptrdiff_t(end),
                       [&](uint32_t w) { return w == value; });
}

void fill(const PassContext& pass, const std::string& buffer, uint32_t value, VkDeviceSize offset = 0,
          VkDeviceSize size = VK_WHOLE_SIZE)
{
    vkCmdFillBuffer(pass.cmd(), pass.buffer(buffer).handle(), offset, size, value);
}

void clearColor(const PassContext& pass, const std::string& image, uint32_t value)
{
    VkClearColorValue color{};
    color.uint32[0] = value;
    const VkImageSubresourceRange range{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    vkCmdClearColorImage(pass.cmd(), pass.image(image).handle(), pass.layout(image), &color, 1, &range);
}

void copyImageToBuffer(const PassContext& pass, const std::string& image, const std::string& buffer,
                       VkDeviceSize offset = 0)
{
    const gpu::Image& source = pass.image(image);
    VkBufferImageCopy region{};
    region.bufferOffset = offset;
    region.imageSubresource = {source.aspect(), 0, 0, 1};
    region.imageExtent = {source.desc().width, source.desc().height, 1};
    vkCmdCopyImageToBuffer(pass.cmd(), source.handle(), pass.layout(image), pass.buffer(buffer).handle(), 1, &region);
}

int resourceIndex(const CompiledGraph& compiled, const std::string& name)
{
    for (size_t r = 0; r < compiled.resources.size(); ++r)
        if (compiled.resources[r].name == name) return int(r);
    return -1;
}

using GraphExecutorTest = test::GpuTest;

} // namespace

TEST_F(GraphExecutorTest, CulledPassNeverExecutes)
{
    // "unread" writes a sentinel into a host-visible imported buffer, but nothing reads
    // what it writes: it is culled, so neither its callback nor its commands may run.
    gpu::Buffer probe(*context, 256, VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT, true,
                      "probe");
    std::memset(probe.mapped(), 0, 256);
    constexpr uint32_t kSentinel = 0xDEADBEEF;
    constexpr uint32_t kKept = 0x1234;

    RenderGraph graph;
    graph.declareBuffer({"probe", 256, true});
    graph.declareBuffer({"scratch", 256, false});
    graph.declareBuffer({"out", 256, false});
    int unreadCalls = 0;
    int keptCalls = 0;
    graph.addPass("unread", QueueKind::Transfer)
        .write("scratch", Usage::TransferDst)
        .write("probe", Usage::TransferDst)
        .execute([&](PassContext& pass) {
            ++unreadCalls;
            fill(pass, "probe", kSentinel);
            fill(pass, "scratch", 1);
        });
    graph.addPass("kept", QueueKind::Transfer).write("out", Usage::TransferDst).execute([&](PassContext& pass) {
        ++keptCalls;
        fill(pass, "out", kKept);
    });
    graph.markOutput("out");

    GraphExecutor executor(*context, kNoTimestamps);
    executor.bindBuffer("probe", probe);
    executor.execute(graph);
    ASSERT_EQ(executor.compiled()->culled.size(), 1u);
    EXPECT_EQ(executor.compiled()->culled[0].name, "unread");
    EXPECT_EQ(unreadCalls, 0);
    EXPECT_EQ(keptCalls, 1);
    EXPECT_TRUE(allEqual(readWords(*context, probe), 0, 64, 0u));
    EXPECT_TRUE(allEqual(readWords(*context, executor.buffer("out")), 0, 64, kKept));
    EXPECT_THROW(executor.buffer("scratch"), Error);  // no executed pass uses it: no object

    // The control: once its output is read, the same pass runs and the sentinel shows,
    // so the probe above could have seen it.
    graph.markOutput("scratch");
    executor.execute(graph);
    EXPECT_EQ(unreadCalls, 1);
    EXPECT_EQ(keptCalls, 2);
    EXPECT_TRUE(allEqual(readWords(*context, probe), 0, 64, kSentinel));
    EXPECT_TRUE(allEqual(readWords(*context, executor.buffer("scratch")), 0, 64, 1u));
}

TEST_F(GraphExecutorTest, ComputeChainProducesTheExpectedValues)
{
    // seed (fill 1.0) -> ramp (v = 3v + i, in place) -> square into an R32F image ->
    // copy the image out: result[i] = (3 + i)^2, exact in float.
    constexpr uint32_t kEdge = 16;
    constexpr uint32_t kCount = kEdge * kEdge;
    const gpu::ShaderCompiler compiler({gpu::engineShaderDir(), kShaders});
    const gpu::Pipeline ramp(*context, compiler,
                             gpu::ComputePipelineDesc{"graph ramp", "graph_ramp.comp", {}, 8});
    const gpu::Pipeline square(*context, compiler,
                               gpu::ComputePipelineDesc{"graph square", "graph_square_to_image.comp", {}, 0});

    RenderGraph graph;
    graph.declareBuffer({"values", kCount * sizeof(float), false});
    graph.declareImage({"field", kEdge, kEdge, VK_FORMAT_R32_SFLOAT, false, {}});
    graph.declareBuffer({"result", kCount * sizeof(float), false});
    graph.addPass("seed", QueueKind::Transfer).write("values", Usage::TransferDst).execute([](PassContext& pass) {
        float one = 1.0f;
        uint32_t bits = 0;
        std::memcpy(&bits, &one, sizeof bits);
        fill(pass, "values", bits);
    });
    graph.addPass("ramp", QueueKind::Compute)
        .read("values", Usage::Storage)
        .write("values", Usage::Storage)
        .execute([&](PassContext& pass) {
            ramp.bind(pass.cmd());
            gpu::DescriptorPush().storageBuffer("Values", pass.buffer("values")).push(pass.context(), pass.cmd(), ramp);
            const struct {
                float scale;
                uint32_t count;
            } push{3.0f, kCount};
            ramp.pushConstants(pass.cmd(), &push, sizeof push);
            ramp.dispatchOver(pass.cmd(), kCount);
        });
    graph.addPass("square", QueueKind::Compute)
        .read("values", Usage::Storage)
        .write("field", Usage::Storage)
        .execute([&](PassContext& pass) {
            EXPECT_EQ(pass.layout("field"), VK_IMAGE_LAYOUT_GENERAL);
            square.bind(pass.cmd());
            gpu::DescriptorPush()
                .storageBuffer("Values", pass.buffer("values"))
                .storageImage("field", pass.image("field"))
                .push(pass.context(), pass.cmd(), square);
            square.dispatchOver(pass.cmd(), kEdge, kEdge);
        });
    graph.addPass("copy out", QueueKind::Transfer)
        .read("field", Usage::TransferSrc)
        .write("result", Usage::TransferDst)
        .execute([](PassContext& pass) { copyImageToBuffer(pass, "field", "result"); });
    graph.markOutput("result");

    GraphExecutor executor(*context);
    executor.execute(graph);
    const std::vector<float> result = readFloats(*context, executor.buffer("result"));
    ASSERT_EQ(result.size(), kCount);
    for (uint32_t i = 0; i < kCount; ++i) {
        const float expected = float(3 + i) * float(3 + i);
        ASSERT_EQ(result[i], expected) << "element " << i;
    }

    const std::vector<PassTiming> timings = executor.collectTimings();
    ASSERT_EQ(timings.size(), 4u);
    const char* order[] = {"seed", "ramp", "square", "copy out"};
    double gpuTotal = 0.0;
    for (size_t i = 0; i < 4; ++i) {
        EXPECT_EQ(timings[i].name, order[i]);
        EXPECT_GE(timings[i].cpuMs, 0.0);
        EXPECT_GE(timings[i].gpuMs, 0.0);
        gpuTotal += timings[i].gpuMs;
    }
    EXPECT_GT(gpuTotal, 0.0);
}

TEST_F(GraphExecutorTest, DepthImagesTransitionWithTheDepthAspect)
{
    // A colour aspect in a depth image's barrier is a validation error; the clear value
    // arriving in the copy shows the transitions happened in order.
    RenderGraph graph;
    graph.declareImage({"depth", 16, 16, VK_FORMAT_D32_SFLOAT, false, {}});
    graph.declareBuffer({"depth copy", 16 * 16 * sizeof(float), false});
    graph.addPass("clear depth", QueueKind::Transfer)
        .write("depth", Usage::TransferDst)
        .execute([](PassContext& pass) {
            const VkClearDepthStencilValue value{0.25f, 0};
            const VkImageSubresourceRange range{VK_IMAGE_ASPECT_DEPTH_BIT, 0, 1, 0, 1};
            vkCmdClearDepthStencilImage(pass.cmd(), pass.image("depth").handle(), pass.layout("depth"), &value, 1,
                                        &range);
        });
    graph.addPass("copy depth", QueueKind::Transfer)
        .read("depth", Usage::TransferSrc)
        .write("depth copy", Usage::TransferDst)
        .execute([](PassContext& pass) { copyImageToBuffer(pass, "depth", "depth copy"); });
    graph.markOutput("depth copy");

    GraphExecutor executor(*context, kNoTimestamps);
    executor.execute(graph);
    for (float v : readFloats(*context, executor.buffer("depth copy"))) ASSERT_EQ(v, 0.25f);
}

TEST_F(GraphExecutorTest, ArrayImagesTransitionEveryLayer)
{
    // Three layers: the whole array cleared, layer 1 again to another value, then every
    // layer copied. A barrier over the first layer alone would leave the others in their
    // old layout (a validation error, and values lost); each layer's value shows the
    // order held.
    constexpr uint32_t kSide = 8, kLayers = 3;
    constexpr VkDeviceSize kLayerBytes = kSide * kSide * sizeof(float);
    RenderGraph graph;
    ImageDesc array{"array", kSide, kSide, VK_FORMAT_R32_SFLOAT};
    array.layers = kLayers;
    graph.declareImage(array);
    graph.declareBuffer({"array copy", kLayers * kLayerBytes, false});
    graph.addPass("clear", QueueKind::Transfer).write("array", Usage::TransferDst).execute([](PassContext& pass) {
        const VkClearColorValue half{{0.5f, 0.0f, 0.0f, 0.0f}}, two{{2.0f, 0.0f, 0.0f, 0.0f}};
        const VkImageSubresourceRange all{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, VK_REMAINING_ARRAY_LAYERS};
        const VkImageSubresourceRange one{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 1, 1};
        const gpu::MemoryAccess transfer{VK_PIPELINE_STAGE_2_CLEAR_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT};
        vkCmdClearColorImage(pass.cmd(), pass.image("array").handle(), pass.layout("array"), &half, 1, &all);
        gpu::memoryBarrier(pass.cmd(), transfer, transfer);
        vkCmdClearColorImage(pass.cmd(), pass.image("array").handle(), pass.layout("array"), &two, 1, &one);
    });
    graph.addPass("copy", QueueKind::Transfer)
        .read("array", Usage::TransferSrc)
        .write("array copy", Usage::TransferDst)
        .execute([&](PassContext& pass) {
            const gpu::Image& image = pass.image("array");
            EXPECT_EQ(image.desc().layers, kLayers);
            VkBufferImageCopy regions[kLayers]{};
            for (uint32_t l = 0; l < kLayers; ++l) {
                regions[l].bufferOffset = l * kLayerBytes;
                regions[l].imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, l, 1};
                regions[l].imageExtent = {kSide, kSide, 1};
            }
            vkCmdCopyImageToBuffer(pass.cmd(), image.handle(), pass.layout("array"), pass.buffer("array copy").handle(),
                                   kLayers, regions);
        });
    graph.markOutput("array copy");
    const CompiledGraph& compiled = *graph.compile();
    const int r = resourceIndex(compiled, "array");
    ASSERT_GE(r, 0);
    EXPECT_EQ(compiled.resources[size_t(r)].sizeBytes, kLayers * kLayerBytes) << "every layer counts";

    GraphExecutor executor(*context, kNoTimestamps);
    executor.execute(graph);
    const std::vector<float> values = readFloats(*context, executor.buffer("array copy"));
    ASSERT_EQ(values.size(), size_t(kLayers * kSide * kSide));
    for (size_t i = 0; i < values.size(); ++i)
        ASSERT_EQ(values[i], i / (kSide * kSide) == 1 ? 2.0f : 0.5f) << "layer " << i / (kSide * kSide);
    EXPECT_EQ(context->validationMessageCount(), 0u);
}

TEST_F(GraphExecutorTest, AliasedTransientsShareMemoryWithoutCorruptingLiveData)
{
    // "first" [0,1] and "second" [2,3] share a slot; "live" [0,3] spans both and must
    // survive; the copies of "first" must hold its value although "second" reused its
    // memory afterwards.
    constexpr uint32_t kEdge = 32;
    constexpr VkDeviceSize kBytes = kEdge * kEdge * sizeof(uint32_t);
    RenderGraph graph;
    for (const char* name : {"first", "second", "live"})
        graph.declareImage({name, kEdge, kEdge, VK_FORMAT_R32_UINT, false, {}});
    graph.declareBuffer({"out first", kBytes, false});
    graph.declareBuffer({"out second", 2 * kBytes, false});
    graph.addPass("write first", QueueKind::Transfer)
        .write("first", Usage::TransferDst)
        .write("live", Usage::TransferDst)
        .execute([](PassContext& pass) {
            clearColor(pass, "first", 7);
            clearColor(pass, "live", 100);
        });
    graph.addPass("read first", QueueKind::Transfer)
        .read("first", Usage::TransferSrc)
        .write("out first", Usage::TransferDst)
        .execute([](PassContext& pass) { copyImageToBuffer(pass, "first", "out first"); });
    graph.addPass("write second", QueueKind::Transfer)
        .write("second", Usage::TransferDst)
        .execute([](PassContext& pass) { clearColor(pass, "second", 9); });
    graph.addPass("read second", QueueKind::Transfer)
        .read("second", Usage::TransferSrc)
        .read("live", Usage::TransferSrc)
        .write("out second", Usage::TransferDst)
        .execute([&](PassContext& pass) {
            copyImageToBuffer(pass, "second", "out second");
            copyImageToBuffer(pass, "live", "out second", kBytes);
        });
    graph.markOutput("out first");
    graph.markOutput("out second");

    GraphExecutor executor(*context, kNoTimestamps);
    executor.execute(graph);
    const CompiledGraph& compiled = *executor.compiled();
    const int first = resourceIndex(compiled, "first");
    const int second = resourceIndex(compiled, "second");
    const int live = resourceIndex(compiled, "live");
    ASSERT_GE(compiled.resources[size_t(first)].memorySlot, 0);
    EXPECT_EQ(compiled.resources[size_t(first)].memorySlot, compiled.resources[size_t(second)].memorySlot);
    EXPECT_NE(compiled.resources[size_t(first)].memorySlot, compiled.resources[size_t(live)].memorySlot);
    EXPECT_LT(executor.transientBytesAllocated(), executor.transientBytesWithoutAliasing());
    // Each resource's own memory, whatever it shares: every transient once, in
    // declaration order, at least its texels, together the unaliased total.
    const std::vector<TransientMemory> memory = executor.transientMemory();
    ASSERT_EQ(memory.size(), 5u);
    VkDeviceSize sum = 0;
    for (size_t i = 0; i < memory.size(); ++i) {
        EXPECT_EQ(memory[i].name, compiled.resources[i].name);
        EXPECT_GE(memory[i].bytes, compiled.resources[i].sizeBytes) << memory[i].name;
        sum += memory[i].bytes;
    }
    EXPECT_EQ(sum, executor.transientBytesWithoutAliasing());

    constexpr size_t kWords = kEdge * kEdge;
    EXPECT_TRUE(allEqual(readWords(*context, executor.buffer("out first")), 0, kWords, 7u));
    const std::vector<uint32_t> outSecond = readWords(*context, executor.buffer("out second"));
    EXPECT_TRUE(allEqual(outSecond, 0, kWords, 9u));
    EXPECT_TRUE(allEqual(outSecond, kWords, 2 * kWords, 100u));
}

namespace {

// What a random transfer graph's pass p does to its k-th written buffer, on the device
// (recordRandomPass) and on the CPU (simulateRandomPass): the buffer is cut in quarters;
// quarter 0 is filled with a value of (p, k); quarter i (1..3) receives the start of the
// pass's i-th read (as much as fits) and the rest of it another value. Contents thus
// flow through chains of passes, and any overwrite of a live buffer by an aliased one
// shows in some marked output.
uint32_t fillValue(size_t pass, size_t write, size_t quarter)
{
    return uint32_t((pass * 977 + write * 131 + quarter * 17 + 1) * 2654435761u);
}

struct QuarterPlan {
    VkDeviceSize offset = 0;  // in the written buffer
    VkDeviceSize copied = 0;  // bytes copied from the read (from its start)
    VkDeviceSize size = 0;    // of the quarter
    const std::string* source = nullptr;
};

std::vector<QuarterPlan> planQuarters(const graphtest::RandomGraph& record, size_t p, const std::string& written)
{
    const VkDeviceSize quarter = record.bufferBytes.at(written) / 4;
    std::vector<QuarterPlan> plan(4);
    for (size_t i = 0; i < 4; ++i) {
        plan[i].offset = i * quarter;
        plan[i].size = quarter;
        if (i > 0 && i - 1 < record.reads[p].size()) {
            plan[i].source = &record.reads[p][i - 1];
            plan[i].copied = std::min(quarter, record.bufferBytes.at(*plan[i].source));
        }
    }
    return plan;
}

void recordRandomPass(const graphtest::RandomGraph& record, size_t p, PassContext& pass)
{
    for (size_t k = 0; k < record.writes[p].size(); ++k) {
        const std::string& written = record.writes[p][k];
        const VkBuffer target = pass.buffer(written).handle();
        for (const QuarterPlan& q : planQuarters(record, p, written)) {
            if (q.copied > 0) {
                const VkBufferCopy region{0, q.offset, q.copied};
                vkCmdCopyBuffer(pass.cmd(), pass.buffer(*q.source).handle(), target, 1, &region);
            }
            if (q.copied < q.size)
                vkCmdFillBuffer(pass.cmd(), target, q.offset + q.copied, q.size - q.copied,
                                fillValue(p, k, q.offset / q.size));
        }
    }
}

void simulateRandomPass(const graphtest::RandomGraph& record, size_t p,
                        std::map<std::string, std::vector<uint32_t>>& contents)
{
    for (size_t k = 0; k < record.writes[p].size(); ++k) {
        const std::string& written = record.writes[p][k];
        std::vector<uint32_t> words(record.bufferBytes.at(written) / 4);
        for (const QuarterPlan& q : planQuarters(record, p, written)) {
            const size_t begin = q.offset / 4;
            const size_t copiedWords = q.copied / 4;
            if (q.copied > 0) {
                const std::vector<uint32_t>& source = contents.at(*q.source);
                std::copy(source.begin(), source.begin() + ptrdiff_t(copiedWords), words.begin() + ptrdiff_t(begin));
            }
            std::fill(words.begin() + ptrdiff_t(begin + copiedWords), words.begin() + ptrdiff_t(begin + q.size / 4),
                      fillValue(p, k, q.offset / q.size));
        }
        contents[written] = std::move(words);
    }
}

} // namespace

TEST_F(GraphExecutorTest, RandomTransferGraphsMatchACpuSimulation)
{
    for (uint32_t seed = 1; seed <= 6; ++seed) {
        SCOPED_TRACE(fmt::format("seed {}", seed));
        graphtest::RandomGraph record;
        graphtest::buildRandomGraph(record, 90, seed, {true});

        std::map<std::string, std::vector<uint32_t>> expected;
        std::vector<gpu::Buffer> imports;
        std::mt19937 rng(seed);
        for (const std::string& name : record.imported) {
            std::vector<uint32_t> words(record.bufferBytes.at(name) / 4);
            for (uint32_t& w : words) w = uint32_t(rng());
            imports.emplace_back(*context, words.size() * 4, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, true, name);
            std::memcpy(imports.back().mapped(), words.data(), words.size() * 4);
            expected[name] = std::move(words);
        }
        for (size_t p = 0; p < record.passNames.size(); ++p) simulateRandomPass(record, p, expected);

        std::vector<int> calls(record.passNames.size(), 0);
        for (size_t p = 0; p < record.passNames.size(); ++p)
            record.passes[p].execute([&record, &calls, p](PassContext& pass) {
                ++calls[p];
                recordRandomPass(record, p, pass);
            });

        GraphExecutor executor(*context, kNoTimestamps);
        for (size_t i = 0; i < imports.size(); ++i) executor.bindBuffer(record.imported[i], imports[i]);
        for (int frame = 1; frame <= 2; ++frame) {
            SCOPED_TRACE(fmt::format("frame {}", frame));
            executor.execute(record.graph);
            for (const std::string& name : record.marked)
                EXPECT_EQ(readWords(*context, executor.buffer(name)), expected.at(name)) << name;
        }

        const CompiledGraph& compiled = *executor.compiled();
        std::vector<int> executed(record.passNames.size(), 0);
        for (const CompiledPass& pass : compiled.passes) executed[pass.declarationIndex] = 2;
        EXPECT_EQ(calls, executed) << "culled passes must never run, executed ones once per frame";
        EXPECT_FALSE(compiled.culled.empty());
        EXPECT_LT(executor.transientBytesAllocated(), executor.transientBytesWithoutAliasing());
    }
}

TEST_F(GraphExecutorTest, ImportedImageReturnsToItsLayoutAndFramesReuseTransients)
{
    constexpr uint32_t kEdge = 8;
    gpu::Image history(*context, {kEdge, kEdge, VK_FORMAT_R32_SFLOAT,
                                  VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT |
                                      VK_IMAGE_USAGE_TRANSFER_DST_BIT,
                                  "history"});
    const gpu::ImageAccess sampled{VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                                   VK_ACCESS_2_SHADER_SAMPLED_READ_BIT};
    context->submitAndWait(
        [&](VkCommandBuffer cmd) { gpu::transition(cmd, history, gpu::access::kUndefined, sampled); });

    float frameValue = 0.0f;
    RenderGraph graph;
    graph.declareImage({"history", kEdge, kEdge, VK_FORMAT_R32_SFLOAT, true, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL});
    graph.declareBuffer({"snapshot", kEdge * kEdge * sizeof(float), false});
    graph.addPass("update history", QueueKind::Transfer)
        .write("history", Usage::TransferDst)
        .execute([&](PassContext& pass) {
            VkClearColorValue color{};
            color.float32[0] = frameValue;
            const VkImageSubresourceRange range{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
            vkCmdClearColorImage(pass.cmd(), pass.image("history").handle(), pass.layout("history"), &color, 1, &range);
        });
    graph.addPass("snapshot history", QueueKind::Transfer)
        .read("history", Usage::TransferSrc)
        .write("snapshot", Usage::TransferDst)
        .execute([](PassContext& pass) { copyImageToBuffer(pass, "history", "snapshot"); });
    graph.markOutput("snapshot");

    GraphExecutor executor(*context);
    executor.bindImage("history", history);
    VkBuffer firstSnapshot = VK_NULL_HANDLE;
    const CompiledGraph* firstCompiled = nullptr;
    for (int frame = 1; frame <= 2; ++frame) {
        SCOPED_TRACE(fmt::format("frame {}", frame));
        frameValue = 1.5f * float(frame);
        executor.execute(graph);
        EXPECT_EQ(executor.finalLayout("history"), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
        // Read back in the declared layout: the layer checks at submission that the image
        // really is in it.
        for (float v : gpu::readImageFloats(*context, history, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL))
            ASSERT_EQ(v, frameValue);
        for (float v : readFloats(*context, executor.buffer("snapshot"))) ASSERT_EQ(v, frameValue);
        if (frame == 1) {
            firstSnapshot = executor.buffer("snapshot").handle();
            firstCompiled = executor.compiled().get();
        } else {
            EXPECT_EQ(executor.compiled().get(), firstCompiled) << "the compiled graph was rebuilt";
            EXPECT_EQ(executor.buffer("snapshot").handle(), firstSnapshot) << "the transient was recreated";
        }
    }
    EXPECT_EQ(executor.collectTimings().size(), 2u);
    // The imported image's memory is its owner's: reported apart from the transients.
    const std::vector<TransientMemory> imported = executor.importedMemory();
    ASSERT_EQ(imported.size(), 1u);
    EXPECT_EQ(imported[0].name, "history");
    EXPECT_EQ(imported[0].bytes, history.memorySize());
    EXPECT_GT(imported[0].bytes, 0u);
    for (const TransientMemory& m : executor.transientMemory()) EXPECT_NE(m.name, "history");
}

TEST_F(GraphExecutorTest, UnboundImportNamesTheResourceAndItsPasses)
{
    RenderGraph graph;
    graph.declareBuffer({"light table", 256, true});
    graph.declareBuffer({"out", 256, false});
    graph.addPass("copy lights", QueueKind::Transfer)
        .read("light table", Usage::TransferSrc)
        .write("out", Usage::TransferDst)
        .execute([](PassContext&) {});
    graph.markOutput("out");
    GraphExecutor executor(*context);
    const std::string message = errorOf([&] { executor.execute(graph); });
    EXPECT_NE(message.find("'light table' is not bound"), std::string::npos) << message;
    EXPECT_NE(message.find("'copy lights'"), std::string::npos) << message;
    EXPECT_NE(message.find("bindBuffer"), std::string::npos) << message;

    gpu::Buffer small(*context, 64, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, false, "small");
    executor.bindBuffer("light table", small);
    const std::string tooSmall = errorOf([&] { executor.execute(graph); });
    EXPECT_NE(tooSmall.find("'light table' is declared 256 bytes"), std::string::npos) << tooSmall;
}

TEST_F(GraphExecutorTest, UndeclaredAccessNamesPassAndResource)
{
    RenderGraph graph;
    graph.declareBuffer({"a", 256, false});
    graph.declareBuffer({"b", 256, false});
    std::string asked = "a";
    graph.addPass("write a", QueueKind::Transfer).write("a", Usage::TransferDst).execute([](PassContext& pass) {
        fill(pass, "a", 1);
    });
    graph.addPass("write b", QueueKind::Transfer)
        .read("a", Usage::TransferSrc)
        .write("b", Usage::TransferDst)
        .execute([&](PassContext& pass) { (void)pass.buffer(asked); });
    graph.markOutput("b");
    graph.markOutput("a");
    GraphExecutor executor(*context);
    EXPECT_NO_THROW(executor.execute(graph));  // "write b" declared "a" (a read)

    // A resource of the graph that "write b" did not declare.
    graph.declareBuffer({"c", 256, false});
    graph.addPass("write c", QueueKind::Transfer).write("c", Usage::TransferDst).execute([](PassContext& pass) {
        fill(pass, "c", 2);
    });
    graph.markOutput("c");
    asked = "c";
    const std::string message = errorOf([&] { executor.execute(graph); });
    EXPECT_NE(message.find("pass 'write b' uses 'c', which it did not declare"), std::string::npos) << message;

    asked = "nonexistent";
    const std::string unknown = errorOf([&] { executor.execute(graph); });
    EXPECT_NE(unknown.find("'nonexistent'"), std::string::npos) << unknown;
    EXPECT_NE(unknown.find("no resource of that name"), std::string::npos) << unknown;

    // Image access to a buffer names the pass too.
    graph.declareImage({"img", 4, 4, VK_FORMAT_R8G8B8A8_UNORM, false, {}});
    graph.addPass("clear img", QueueKind::Transfer).write("img", Usage::TransferDst).execute([](PassContext& pass) {
        (void)pass.buffer("img");
    });
    graph.markOutput("img");
    asked = "a";
    const std::string wrongKind = errorOf([&] { executor.execute(graph); });
    EXPECT_NE(wrongKind.find("pass 'clear img' asks for buffer 'img', which is an image"), std::string::npos)
        << wrongKind;
}

TEST_F(GraphExecutorTest, CallbackExceptionsAndMissingCallbacksNameThePass)
{
    RenderGraph graph;
    graph.declareBuffer({"out", 256, false});
    PassBuilder pass = graph.addPass("shade", QueueKind::Transfer).write("out", Usage::TransferDst);
    graph.markOutput("out");
    GraphExecutor executor(*context);

    const std::string missing = errorOf([&] { executor.execute(graph); });
    EXPECT_NE(missing.find("pass 'shade'"), std::string::npos) << missing;
    EXPECT_NE(missing.find("no execute callback"), std::string::npos) << missing;

    pass.execute([](PassContext&) { throw std::runtime_error("pipeline 'shade.frag' is missing"); });
    const std::string failed = errorOf([&] { executor.execute(graph); });
    EXPECT_NE(failed.find("render graph: pass 'shade' failed while recording: pipeline 'shade.frag' is missing"),
              std::string::npos)
        << failed;
    EXPECT_THROW(executor.collectTimings(), Error);

    // Setting the callback did not change the declaration: the same compiled graph runs.
    const CompiledGraph* compiled = executor.compiled().get();
    pass.execute([](PassContext& p) { fill(p, "out", 5); });
    executor.execute(graph);
    EXPECT_EQ(executor.compiled().get(), compiled);
    EXPECT_TRUE(allEqual(readWords(*context, executor.buffer("out")), 0, 64, 5u));

    EXPECT_NE(errorOf([&] { executor.buffer("nope"); }).find("no resource 'nope'"), std::string::npos);
    EXPECT_NE(errorOf([&] { executor.image("out"); }).find("'out' is a buffer"), std::string::npos);
}

// ---------------------------------------------------------------------------------------
// Host passes: CPU work between GPU passes in one frame.

namespace {

const Barrier* barrierOn(const CompiledPass& pass, int resource)
{
    for (const Barrier& b : pass.barriersBefore)
        if (int(b.resource) == resource) return &b;
    return nullptr;
}

const CompiledPass* passNamed(const CompiledGraph& compiled, const std::string& name)
{
    for (const CompiledPass& pass : compiled.passes)
        if (pass.name == name) return &pass;
    return nullptr;
}

} // namespace

TEST_F(GraphExecutorTest, TransferHostTransferChainRoundTripsDataExactly)
{
    // An imported source -> "stage" (device-local) -> "down" (host-readable) -> the host
    // pass reverses the words and adds the frame number into "up" (host-writable) ->
    // "result" (device-local). Every word of the result is checked, two frames in a row,
    // with GPU timestamps on (the host pass splits the frame into two submissions).
    constexpr uint32_t kWords = 1024;
    constexpr VkDeviceSize kBytes = kWords * sizeof(uint32_t);
    std::vector<uint32_t> source(kWords);
    std::mt19937 rng(7);
    for (uint32_t& w : source) w = uint32_t(rng());
    gpu::Buffer input(*context, kBytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, true, "input");
    std::memcpy(input.mapped(), source.data(), kBytes);

    uint32_t frame = 0;
    int hostCalls = 0;
    std::vector<uint32_t> seenByHost;
    RenderGraph graph;
    graph.declareBuffer({"input", kBytes, true});
    for (const char* name : {"stage", "down", "up", "result"}) graph.declareBuffer({name, kBytes, false});
    graph.addPass("stage", QueueKind::Transfer)
        .read("input", Usage::TransferSrc)
        .write("stage", Usage::TransferDst)
        .execute([&](PassContext& pass) {
            const VkBufferCopy region{0, 0, kBytes};
            vkCmdCopyBuffer(pass.cmd(), pass.buffer("input").handle(), pass.buffer("stage").handle(), 1, &region);
        });
    graph.addPass("read back", QueueKind::Transfer)
        .read("stage", Usage::TransferSrc)
        .write("down", Usage::TransferDst)
        .execute([&](PassContext& pass) {
            const VkBufferCopy region{0, 0, kBytes};
            vkCmdCopyBuffer(pass.cmd(), pass.buffer("stage").handle(), pass.buffer("down").handle(), 1, &region);
        });
    graph.addPass("on the cpu", QueueKind::Host)
        .read("down", Usage::HostRead)
        .write("up", Usage::HostWrite)
        .execute([&](PassContext& pass) {
            ++hostCalls;
            EXPECT_EQ(pass.cmd(), VK_NULL_HANDLE);
            const std::span<std::byte> down = pass.hostMemory("down");
            const std::span<std::byte> up = pass.hostMemory("up");
            ASSERT_EQ(down.size(), kBytes);
            ASSERT_EQ(up.size(), kBytes);
            seenByHost.resize(kWords);
            std::memcpy(seenByHost.data(), down.data(), kBytes);
            std::vector<uint32_t> out(seenByHost.rbegin(), seenByHost.rend());
            for (uint32_t& w : out) w += frame;
            std::memcpy(up.data(), out.data(), kBytes);
            // Long enough that the pass's CPU time cannot be anything but its own.
            std::this_thread::sleep_for(std::chrono::milliseconds(5));
        });
    graph.addPass("upload", QueueKind::Transfer)
        .read("up", Usage::TransferSrc)
        .write("result", Usage::TransferDst)
        .execute([&](PassContext& pass) {
            const VkBufferCopy region{0, 0, kBytes};
            vkCmdCopyBuffer(pass.cmd(), pass.buffer("up").handle(), pass.buffer("result").handle(), 1, &region);
        });
    graph.markOutput("result");

    GraphExecutor executor(*context);
    executor.bindBuffer("input", input);
    for (frame = 1; frame <= 2; ++frame) {
        SCOPED_TRACE(fmt::format("frame {}", frame));
        executor.execute(graph);
        EXPECT_EQ(hostCalls, int(frame));
        EXPECT_EQ(seenByHost, source);
        const std::vector<uint32_t> result = readWords(*context, executor.buffer("result"));
        ASSERT_EQ(result.size(), kWords);
        for (uint32_t i = 0; i < kWords; ++i) ASSERT_EQ(result[i], source[kWords - 1 - i] + frame) << "word " << i;

        const std::vector<PassTiming> timings = executor.collectTimings();
        ASSERT_EQ(timings.size(), 4u);
        EXPECT_EQ(timings[2].name, "on the cpu");
        EXPECT_EQ(timings[2].gpuMs, 0.0);
        EXPECT_GE(timings[2].cpuMs, 5.0);
        EXPECT_GT(timings[0].gpuMs + timings[1].gpuMs + timings[3].gpuMs, 0.0) << "GPU passes on both sides are timed";
    }

    // The barriers carry the HOST stage: device writes made available to the host before
    // the host pass, the host's writes ordered before the upload.
    const CompiledGraph& compiled = *executor.compiled();
    const int down = resourceIndex(compiled, "down");
    const int up = resourceIndex(compiled, "up");
    const Barrier* toHost = barrierOn(*passNamed(compiled, "on the cpu"), down);
    ASSERT_NE(toHost, nullptr);
    EXPECT_EQ(toHost->srcStage, VK_PIPELINE_STAGE_2_TRANSFER_BIT);
    EXPECT_EQ(toHost->srcAccess, VK_ACCESS_2_TRANSFER_WRITE_BIT);
    EXPECT_EQ(toHost->dstStage, VK_PIPELINE_STAGE_2_HOST_BIT);
    EXPECT_EQ(toHost->dstAccess, VK_ACCESS_2_HOST_READ_BIT);
    const Barrier* fromHost = barrierOn(*passNamed(compiled, "upload"), up);
    ASSERT_NE(fromHost, nullptr);
    EXPECT_EQ(fromHost->srcStage, VK_PIPELINE_STAGE_2_HOST_BIT);
    EXPECT_EQ(fromHost->srcAccess, VK_ACCESS_2_HOST_WRITE_BIT);
    EXPECT_EQ(fromHost->dstStage, VK_PIPELINE_STAGE_2_TRANSFER_BIT);
    EXPECT_EQ(fromHost->dstAccess, VK_ACCESS_2_TRANSFER_READ_BIT);

    // "stage" is dead before "up" is born, and as large: only the kind of memory keeps
    // them apart. No slot mixes the two kinds.
    const CompiledResource& stage = compiled.resources[size_t(resourceIndex(compiled, "stage"))];
    EXPECT_LT(stage.lastUse, compiled.resources[size_t(up)].firstUse);
    EXPECT_TRUE(compiled.resources[size_t(down)].hostVisible);
    EXPECT_TRUE(compiled.resources[size_t(up)].hostVisible);
    EXPECT_FALSE(stage.hostVisible);
    EXPECT_NE(stage.memorySlot, compiled.resources[size_t(up)].memorySlot);
    for (const MemorySlot& slot : compiled.memorySlots)
        for (uint32_t r : slot.resources) EXPECT_EQ(compiled.resources[r].hostVisible, slot.hostVisible);

    const std::string text = compiled.toText();
    EXPECT_NE(text.find("2 on the cpu (host)"), std::string::npos) << text;
    EXPECT_NE(text.find("-> { Host } { HostRead }"), std::string::npos) << text;
    EXPECT_NE(text.find("down: buffer, 0.00 MiB, host-visible"), std::string::npos) << text;
    EXPECT_NE(compiled.toDot().find("host"), std::string::npos);
}

// A read-back (RenderGraph::readBack): the frame's result is in the owner's mapped memory
// once execute() returns, through the graph's barrier alone (no pass of the frame waits
// for it), and only a host-visible buffer can be bound to one.
TEST_F(GraphExecutorTest, ReadBackIsInMappedMemoryWhenTheFrameReturns)
{
    RenderGraph graph;
    graph.declareBuffer({"counts", 256, false});
    graph.declareBuffer({"last counts", 256, true});
    uint32_t frame = 0;
    graph.addPass("count", QueueKind::Transfer).write("counts", Usage::TransferDst).execute([&](PassContext& pass) {
        fill(pass, "counts", 100 + frame);
    });
    graph.addPass("copy", QueueKind::Transfer)
        .read("counts", Usage::TransferSrc)
        .write("last counts", Usage::TransferDst)
        .execute([](PassContext& pass) {
            const VkBufferCopy region{0, 0, 256};
            vkCmdCopyBuffer(pass.cmd(), pass.buffer("counts").handle(), pass.buffer("last counts").handle(), 1, &region);
        });
    graph.readBack("last counts");

    GraphExecutor executor(*context, kNoTimestamps);
    gpu::Buffer deviceOnly(*context, 256, VK_BUFFER_USAGE_TRANSFER_DST_BIT, false, "device only");
    executor.bindBuffer("last counts", deviceOnly);
    const std::string unmapped = errorOf([&] { executor.execute(graph); });
    EXPECT_NE(unmapped.find("imported buffer 'last counts' is read back by the host (RenderGraph::readBack) but the "
                            "bound buffer is not host-visible"),
              std::string::npos)
        << unmapped;

    gpu::Buffer last(*context, 256, VK_BUFFER_USAGE_TRANSFER_DST_BIT, true, "last counts");
    std::memset(last.mapped(), 0, 256);
    executor.bindBuffer("last counts", last);
    for (frame = 1; frame <= 2; ++frame) {
        executor.execute(graph);
        std::vector<uint32_t> words(64);
        std::memcpy(words.data(), last.mapped(), 256);
        EXPECT_TRUE(allEqual(words, 0, 64, 100 + frame)) << "frame " << frame << ": " << words[0];
    }
    EXPECT_TRUE(executor.compiled()->culled.empty()) << "the read-back keeps its writers";
}

TEST_F(GraphExecutorTest, HostPassNobodyReadsIsCulledAndNeverRuns)
{
    constexpr VkDeviceSize kBytes = 256;
    int hostCalls = 0;
    RenderGraph graph;
    graph.declareBuffer({"down", kBytes, false});
    graph.declareBuffer({"unread", kBytes, false});
    graph.declareBuffer({"out", kBytes, false});
    graph.addPass("read back", QueueKind::Transfer).write("down", Usage::TransferDst).execute([](PassContext& pass) {
        fill(pass, "down", 3);
    });
    graph.addPass("analyse", QueueKind::Host)
        .read("down", Usage::HostRead)
        .write("unread", Usage::HostWrite)
        .execute([&](PassContext&) { ++hostCalls; });
    graph.addPass("kept", QueueKind::Transfer).write("out", Usage::TransferDst).execute([](PassContext& pass) {
        fill(pass, "out", 4);
    });
    graph.markOutput("out");

    GraphExecutor executor(*context, kNoTimestamps);
    executor.execute(graph);
    const CompiledGraph& compiled = *executor.compiled();
    std::vector<std::string> culled;
    for (const CulledPass& pass : compiled.culled) culled.push_back(pass.name);
    EXPECT_EQ(culled, (std::vector<std::string>{"read back", "analyse"}));
    EXPECT_EQ(hostCalls, 0);
    EXPECT_TRUE(allEqual(readWords(*context, executor.buffer("out")), 0, 64, 4u));

    // The control: read what it writes and it runs, once per frame.
    graph.markOutput("unread");
    executor.execute(graph);
    EXPECT_EQ(hostCalls, 1);
}

TEST_F(GraphExecutorTest, HostPassMisuseNamesThePass)
{
    const auto compileError = [](const std::function<void(RenderGraph&)>& declare) {
        RenderGraph graph;
        graph.declareBuffer({"buf", 256, false});
        graph.declareImage({"img", 4, 4, VK_FORMAT_R32_SFLOAT, false, {}});
        declare(graph);
        return errorOf([&] { graph.compile(); });
    };
    EXPECT_NE(compileError([](RenderGraph& g) { g.addPass("cpu", QueueKind::Host).write("img", Usage::HostWrite); })
                  .find("pass 'cpu', resource 'img': host write usage needs a buffer, not an image"),
              std::string::npos);
    EXPECT_NE(compileError([](RenderGraph& g) { g.addPass("cpu", QueueKind::Host).write("buf", Usage::TransferDst); })
                  .find("pass 'cpu', resource 'buf': transfer destination usage is not available on a host pass"),
              std::string::npos);
    EXPECT_NE(compileError([](RenderGraph& g) { g.addPass("copy", QueueKind::Transfer).write("buf", Usage::HostWrite); })
                  .find("pass 'copy', resource 'buf': host write usage is not available on a transfer pass"),
              std::string::npos);
    EXPECT_NE(compileError([](RenderGraph& g) { g.addPass("shade", QueueKind::Compute).write("buf", Usage::HostWrite); })
                  .find("pass 'shade', resource 'buf': host write usage needs a host pass"),
              std::string::npos);

    // record() fills one command buffer: it cannot wait for the GPU before a host pass.
    RenderGraph graph;
    graph.declareBuffer({"buf", 256, true});
    std::string asked = "buf";
    graph.addPass("cpu", QueueKind::Host).write("buf", Usage::HostWrite).execute([&](PassContext& pass) {
        (void)pass.hostMemory(asked);
    });
    graph.declareBuffer({"gpu", 256, false});
    PassBuilder gpuPass =
        graph.addPass("gpu", QueueKind::Transfer).write("gpu", Usage::TransferDst).execute([](PassContext& pass) {
            (void)pass.hostMemory("gpu");
        });
    graph.markOutput("buf");
    graph.markOutput("gpu");
    GraphExecutor executor(*context, kNoTimestamps);
    gpu::Buffer deviceOnly(*context, 256, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, false, "device only");
    executor.bindBuffer("buf", deviceOnly);
    const std::string unmapped = errorOf([&] { executor.execute(graph); });
    EXPECT_NE(unmapped.find("imported buffer 'buf' is used by the host passes 'cpu' but the bound buffer is not "
                            "host-visible"),
              std::string::npos)
        << unmapped;

    gpu::Buffer mapped(*context, 256, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, true, "mapped");
    executor.bindBuffer("buf", mapped);
    const std::string recorded = errorOf([&] {
        context->submitAndWait([&](VkCommandBuffer cmd) { executor.record(cmd, graph); });
    });
    EXPECT_NE(recorded.find("pass 'cpu' is a host pass: record() fills one command buffer"), std::string::npos)
        << recorded;

    // A GPU pass may not touch mapped memory; the failure leaves the executor's command
    // buffer recording, and the next frame must still run.
    const std::string gpuError = errorOf([&] { executor.execute(graph); });
    EXPECT_NE(gpuError.find("pass 'gpu' failed while recording: render graph: pass 'gpu' asks for the host memory "
                            "of 'gpu' but is not a host pass"),
              std::string::npos)
        << gpuError;
    gpuPass.execute([](PassContext& pass) { fill(pass, "gpu", 6); });
    asked = "nonexistent";
    const std::string hostError = errorOf([&] { executor.execute(graph); });
    EXPECT_NE(hostError.find("pass 'cpu' failed while running on the host: render graph: pass 'cpu' uses "
                             "'nonexistent', which it did not declare"),
              std::string::npos)
        << hostError;
    asked = "buf";
    executor.execute(graph);
    EXPECT_TRUE(allEqual(readWords(*context, executor.buffer("gpu")), 0, 64, 6u));
}

// Keeping what did not change (PassBuilder::dependsOn): "draw" depends on the light and
// clears a persistent image to the light's value; "combine" depends on the camera and
// copies that image, plus the camera's value, into the output; "every" declares no state.
// Each frame's output must be what running every pass would give, whichever passes ran,
// under synchronization validation (the kept image's layouts across frames).
TEST_F(GraphExecutorTest, KeptPassesRunOnlyWhenTheirStatesOrInputsChange)
{
    constexpr uint32_t kEdge = 4;
    constexpr VkDeviceSize kImageBytes = kEdge * kEdge * sizeof(uint32_t);
    uint32_t lightValue = 10, cameraValue = 100, everyValue = 1000;
    std::map<std::string, int> calls;
    const auto build = [&](RenderGraph& graph) {
        graph.declareImage({"map", kEdge, kEdge, VK_FORMAT_R32_UINT});
        graph.declareBuffer({"out", kImageBytes + 256, false});
        graph.declareBuffer({"every", 256, false});
        graph.addPass("draw", QueueKind::Transfer)
            .write("map", Usage::TransferDst)
            .dependsOn("light")
            .execute([&](PassContext& pass) {
                ++calls["draw"];
                clearColor(pass, "map", lightValue);
            });
        graph.addPass("combine", QueueKind::Transfer)
            .read("map", Usage::TransferSrc)
            .write("out", Usage::TransferDst)
            .dependsOn("camera")
            .execute([&](PassContext& pass) {
                ++calls["combine"];
                fill(pass, "out", cameraValue, kImageBytes, 256);
                copyImageToBuffer(pass, "map", "out");
            });
        graph.addPass("every", QueueKind::Transfer).write("every", Usage::TransferDst).execute([&](PassContext& pass) {
            ++calls["every"];
            fill(pass, "every", everyValue);
        });
        graph.markOutput("out");
        graph.markOutput("every");
    };
    RenderGraph graph;
    build(graph);
    GraphExecutor executor(*context, kNoTimestamps);
    const auto frame = [&](const std::string& what, std::map<std::string, int> expectedCalls) {
        SCOPED_TRACE(what);
        calls.clear();
        executor.execute(graph);
        for (const auto& [pass, count] : expectedCalls) EXPECT_EQ(calls[pass], count) << pass;
        const std::vector<uint32_t> out = readWords(*context, executor.buffer("out"));
        EXPECT_TRUE(allEqual(out, 0, kEdge * kEdge, lightValue)) << out[0];
        EXPECT_TRUE(allEqual(out, kEdge * kEdge, out.size(), cameraValue)) << out.back();
        EXPECT_TRUE(allEqual(readWords(*context, executor.buffer("every")), 0, 64, everyValue));
        std::map<std::string, bool> kept;
        for (const PassTiming& t : executor.collectTimings()) kept[t.name] = t.kept;
        for (const auto& [pass, count] : expectedCalls) EXPECT_EQ(kept[pass], count == 0) << pass << " kept";
    };

    frame("a state never set: every pass runs", {{"draw", 1}, {"combine", 1}, {"every", 1}});
    graph.setState("light", 1);
    graph.setState("camera", 1);
    frame("first frame with states", {{"draw", 1}, {"combine", 1}, {"every", 1}});
    frame("nothing changed", {{"draw", 0}, {"combine", 0}, {"every", 1}});
    everyValue = 1001;
    frame("an every-frame pass that nothing kept reads", {{"draw", 0}, {"combine", 0}, {"every", 1}});
    cameraValue = 101;
    graph.setState("camera", 2);
    frame("the camera: combine runs and reads the kept map", {{"draw", 0}, {"combine", 1}, {"every", 1}});
    lightValue = 11;
    graph.setState("light", 2);
    frame("the light: draw runs, and combine, which reads its map", {{"draw", 1}, {"combine", 1}, {"every", 1}});
    frame("still again", {{"draw", 0}, {"combine", 0}, {"every", 1}});

    // What a kept pass writes has memory of its own; what it reads need not.
    const CompiledGraph& compiled = *executor.compiled();
    const CompiledResource& map = compiled.resources.at(size_t(resourceIndex(compiled, "map")));
    EXPECT_TRUE(map.persistent);
    ASSERT_GE(map.memorySlot, 0);
    EXPECT_EQ(compiled.memorySlots.at(size_t(map.memorySlot)).resources.size(), 1u);
    EXPECT_FALSE(compiled.resources.at(size_t(resourceIndex(compiled, "every"))).persistent);

    // A callback that throws leaves nothing to keep: the next frame runs everything.
    bool fail = false;
    RenderGraph failing;
    build(failing);
    failing.declareBuffer({"sink", 256, false});
    failing.addPass("fails", QueueKind::Transfer)
        .read("out", Usage::TransferSrc)
        .write("sink", Usage::TransferDst)
        .execute([&](PassContext& pass) {
            if (fail) throw Error("boom");
            fill(pass, "sink", 1);
        });
    failing.markOutput("sink");
    failing.setState("light", 1);
    failing.setState("camera", 1);
    GraphExecutor second(*context, kNoTimestamps);
    second.execute(failing);
    calls.clear();
    second.execute(failing);
    EXPECT_EQ(calls["draw"], 0);
    fail = true;
    EXPECT_THROW(second.execute(failing), Error);
    fail = false;
    calls.clear();
    second.execute(failing);
    EXPECT_EQ(calls["draw"], 1) << "a failed frame's results were kept";
    EXPECT_EQ(calls["combine"], 1);
}

// Keeping off (RenderGraph::setKeepUnchanged(false)) runs every pass every frame and
// keeps nothing persistent; a pass that shares what it writes with a pass that runs every
// frame is never kept.
TEST_F(GraphExecutorTest, KeepingOffAndSharedWritesRunEveryFrame)
{
    int draws = 0, shares = 0;
    RenderGraph graph;
    graph.declareBuffer({"map", 256, false});
    graph.declareBuffer({"shared", 256, false});
    graph.declareBuffer({"order", 256, false});  // puts "add" after "clear shared"
    graph.addPass("draw", QueueKind::Transfer).write("map", Usage::TransferDst).dependsOn("light").execute([&](PassContext& pass) {
        ++draws;
        fill(pass, "map", 7);
    });
    graph.addPass("clear shared", QueueKind::Transfer)
        .write("shared", Usage::TransferDst)
        .write("order", Usage::TransferDst)
        .execute([&](PassContext& pass) {
            fill(pass, "shared", 0);
            fill(pass, "order", 0);
        });
    graph.addPass("add", QueueKind::Transfer)
        .read("map", Usage::TransferSrc)
        .read("order", Usage::TransferSrc)
        .write("shared", Usage::TransferDst)
        .dependsOn("light")
        .execute([&](PassContext& pass) {
            ++shares;
            const VkBufferCopy region{0, 0, 128};
            vkCmdCopyBuffer(pass.cmd(), pass.buffer("map").handle(), pass.buffer("shared").handle(), 1, &region);
        });
    graph.markOutput("shared");
    graph.setState("light", 1);

    GraphExecutor keeping(*context, kNoTimestamps);
    for (int frame = 0; frame < 3; ++frame) keeping.execute(graph);
    EXPECT_EQ(draws, 1);
    EXPECT_EQ(shares, 3) << "'add' writes what 'clear shared' rewrites every frame";
    for (const CompiledPass& pass : keeping.compiled()->passes)
        EXPECT_EQ(pass.keptWhile.empty(), pass.name != "draw") << pass.name;
    std::vector<uint32_t> words = readWords(*context, keeping.buffer("shared"));
    EXPECT_TRUE(allEqual(words, 0, 32, 7u));
    EXPECT_TRUE(allEqual(words, 32, 64, 0u));

    graph.setKeepUnchanged(false);
    GraphExecutor uncached(*context, kNoTimestamps);
    draws = shares = 0;
    for (int frame = 0; frame < 3; ++frame) uncached.execute(graph);
    EXPECT_EQ(draws, 3);
    EXPECT_EQ(shares, 3);
    for (const CompiledResource& res : uncached.compiled()->resources) EXPECT_FALSE(res.persistent) << res.name;
}
