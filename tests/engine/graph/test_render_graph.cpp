// The pass scheduler's CPU core: ordering, culling, lifetimes and aliasing (checked
// against the generator's own record, not the compiler's), errors, barriers, printing.
#include "RandomGraph.h"
#include "penumbra/core/Error.h"
#include "penumbra/graph/RenderGraph.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <map>
#include <set>

using namespace penumbra;
using namespace penumbra::graph;

namespace {

std::vector<std::string> passOrder(const CompiledGraph& compiled)
{
    std::vector<std::string> names;
    for (const CompiledPass& pass : compiled.passes) names.push_back(pass.name);
    return names;
}

std::vector<std::string> culledNames(const CompiledGraph& compiled)
{
    std::vector<std::string> names;
    for (const CulledPass& pass : compiled.culled) names.push_back(pass.name);
    return names;
}

void declareColor(RenderGraph& graph, const std::string& name, uint32_t edge = 1024)
{
    graph.declareImage({name, edge, edge, VK_FORMAT_R8G8B8A8_UNORM, false, {}});
}

const CompiledPass& passNamed(const CompiledGraph& compiled, const std::string& name)
{
    for (const CompiledPass& pass : compiled.passes)
        if (pass.name == name) return pass;
    throw std::runtime_error("no pass " + name);
}

const Barrier* barrierFor(const CompiledGraph& compiled, const std::string& pass, const std::string& resource)
{
    for (const Barrier& b : passNamed(compiled, pass).barriersBefore)
        if (compiled.resources[b.resource].name == resource) return &b;
    return nullptr;
}

void expectThrowContaining(const std::function<void()>& action, const std::vector<std::string>& parts)
{
    try {
        action();
        ADD_FAILURE() << "no exception";
    } catch (const Error& e) {
        for (const std::string& part : parts) EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
    }
}

} // namespace

TEST(RenderGraph, OrdersByDependencyAndKeepsDeclarationOrderOtherwise)
{
    RenderGraph graph;
    declareColor(graph, "gbuffer");
    declareColor(graph, "shadow");
    declareColor(graph, "color");
    graph.addPass("shade", QueueKind::Graphics).read("gbuffer", Usage::Sampled).read("shadow", Usage::Sampled)
        .write("color", Usage::ColorAttachment);
    graph.addPass("gbuffer", QueueKind::Graphics).write("gbuffer", Usage::ColorAttachment);
    graph.addPass("ui", QueueKind::Graphics, true);
    graph.addPass("shadow", QueueKind::Graphics).write("shadow", Usage::ColorAttachment);
    graph.markOutput("color");
    const auto compiled = graph.compile();
    EXPECT_EQ(passOrder(*compiled), (std::vector<std::string>{"gbuffer", "ui", "shadow", "shade"}));
    EXPECT_TRUE(compiled->culled.empty());
}

TEST(RenderGraph, CulledPassesNeverRunAndTheirProducersAreCulledToo)
{
    RenderGraph graph;
    declareColor(graph, "a");
    declareColor(graph, "debug");
    declareColor(graph, "color");
    graph.declareBuffer({"stats", 256, false});
    graph.addPass("feedsDebugOnly", QueueKind::Graphics).write("a", Usage::ColorAttachment);
    graph.addPass("debugView", QueueKind::Compute).read("a", Usage::Storage).write("debug", Usage::Storage);
    graph.addPass("main", QueueKind::Graphics).write("color", Usage::ColorAttachment);
    graph.addPass("readback", QueueKind::Transfer, true).write("stats", Usage::TransferDst);
    graph.markOutput("color");
    const auto compiled = graph.compile();
    EXPECT_EQ(passOrder(*compiled), (std::vector<std::string>{"main", "readback"}));
    EXPECT_EQ(culledNames(*compiled), (std::vector<std::string>{"feedsDebugOnly", "debugView"}));
    for (const CulledPass& pass : compiled->culled)
        EXPECT_EQ(pass.reason, "no marked output or side effect reads its outputs");
    EXPECT_EQ(compiled->resources[0].firstUse, -1) << "a culled pass's resource is never allocated";
    EXPECT_EQ(compiled->resources[0].memorySlot, -1);

    // A debug view asks for any written image by name (FrameRenderer::requestImage):
    // marked, it keeps its culled producers.
    EXPECT_EQ(graph.writtenImages(), (std::vector<std::string>{"a", "debug", "color"}));
    graph.markOutput("debug");
    EXPECT_EQ(passOrder(*graph.compile()),
              (std::vector<std::string>{"feedsDebugOnly", "debugView", "main", "readback"}));
}

TEST(RenderGraph, CompileReusesTheResultWhileTheDeclarationIsUnchanged)
{
    RenderGraph graph;
    declareColor(graph, "color");
    graph.addPass("main", QueueKind::Graphics).write("color", Usage::ColorAttachment);
    graph.markOutput("color");
    const auto first = graph.compile();
    EXPECT_EQ(graph.compile(), first);
    declareColor(graph, "color");  // the same description again: nothing changed
    graph.markOutput("color");
    EXPECT_EQ(graph.compile(), first);
    graph.addPass("post", QueueKind::Compute).read("color", Usage::Storage);
    EXPECT_NE(graph.compile(), first);
}

// ---------------------------------------------------------------------------------------
// Lifetimes and aliasing against an independent checker

namespace {

// Recomputes liveness and lifetimes from the generator's record and the compiled order
// alone, then checks what the compiler claims.
void checkAgainstRecord(const graphtest::RandomGraph& record, const CompiledGraph& compiled)
{
    std::map<std::string, size_t> passIndex;
    for (size_t p = 0; p < record.passNames.size(); ++p) passIndex[record.passNames[p]] = p;
    std::map<std::string, size_t> writerOf;
    for (size_t p = 0; p < record.writes.size(); ++p)
        for (const std::string& r : record.writes[p]) writerOf[r] = p;

    // Live: side effects, writers of marked outputs, and the writers of what live passes read.
    std::vector<bool> live(record.passNames.size(), false);
    std::vector<size_t> stack;
    for (size_t p = 0; p < live.size(); ++p) {
        bool root = record.sideEffect[p];
        for (const std::string& r : record.writes[p])
            root = root || std::count(record.marked.begin(), record.marked.end(), r) > 0;
        if (root) live[p] = true, stack.push_back(p);
    }
    while (!stack.empty()) {
        const size_t p = stack.back();
        stack.pop_back();
        for (const std::string& r : record.reads[p]) {
            const auto w = writerOf.find(r);
            if (w != writerOf.end() && !live[w->second]) live[w->second] = true, stack.push_back(w->second);
        }
    }

    std::map<std::string, int> position;
    for (size_t i = 0; i < compiled.passes.size(); ++i) position[compiled.passes[i].name] = int(i);
    ASSERT_EQ(position.size(), compiled.passes.size()) << "a pass appears twice";
    for (size_t p = 0; p < live.size(); ++p)
        EXPECT_EQ(position.count(record.passNames[p]) == 1, bool(live[p])) << record.passNames[p];
    for (const CulledPass& culled : compiled.culled) {
        EXPECT_EQ(position.count(culled.name), 0u) << culled.name << " is culled but scheduled";
        EXPECT_FALSE(live[passIndex[culled.name]]);
    }
    EXPECT_EQ(compiled.passes.size() + compiled.culled.size(), record.passNames.size());

    // Order: every read comes after its writer. Lifetimes: the span of the accesses,
    // stretched to the last pass for marked outputs.
    std::map<std::string, std::pair<int, int>> lifetime;
    for (const CompiledPass& pass : compiled.passes) {
        const size_t p = passIndex[pass.name];
        const int at = position[pass.name];
        for (const std::string& r : record.reads[p]) {
            if (writerOf.count(r)) {
                EXPECT_LT(position.at(record.passNames[writerOf[r]]), at) << r;
            }
        }
        for (const auto* list : {&record.reads[p], &record.writes[p]})
            for (const std::string& r : *list) {
                auto [it, fresh] = lifetime.try_emplace(r, at, at);
                if (!fresh) it->second = {std::min(it->second.first, at), std::max(it->second.second, at)};
            }
    }
    for (const std::string& r : record.marked)
        if (lifetime.count(r)) lifetime[r].second = int(compiled.passes.size()) - 1;

    std::map<int, std::vector<std::string>> slots;
    for (const CompiledResource& res : compiled.resources) {
        const bool used = lifetime.count(res.name) == 1;
        EXPECT_EQ(res.firstUse >= 0, used) << res.name;
        if (used) {
            EXPECT_EQ(res.firstUse, lifetime[res.name].first) << res.name;
            EXPECT_EQ(res.lastUse, lifetime[res.name].second) << res.name;
        }
        const bool isImported = std::count(record.imported.begin(), record.imported.end(), res.name) > 0;
        EXPECT_EQ(res.memorySlot >= 0, used && !isImported) << res.name;
        if (res.memorySlot >= 0) {
            slots[res.memorySlot].push_back(res.name);
            EXPECT_GE(compiled.memorySlots[size_t(res.memorySlot)].sizeBytes, res.sizeBytes) << res.name;
        }
    }
    for (const auto& [slot, members] : slots)
        for (size_t i = 0; i < members.size(); ++i)
            for (size_t j = i + 1; j < members.size(); ++j) {
                const auto a = lifetime[members[i]];
                const auto b = lifetime[members[j]];
                EXPECT_TRUE(a.second < b.first || b.second < a.first)
                    << members[i] << " [" << a.first << "," << a.second << "] and " << members[j] << " ["
                    << b.first << "," << b.second << "] share slot " << slot;
            }
}

} // namespace

TEST(RenderGraph, RandomGraphsNeverAliasOverlappingLifetimes)
{
    for (uint32_t seed = 1; seed <= 12; ++seed) {
        SCOPED_TRACE(seed);
        graphtest::RandomGraph record;
        graphtest::buildRandomGraph(record, seed % 3 == 0 ? 600 : 250, seed);
        const auto compiled = record.graph.compile();
        checkAgainstRecord(record, *compiled);
        EXPECT_GT(compiled->passes.size(), 10u);
        EXPECT_FALSE(compiled->culled.empty());
        EXPECT_LT(compiled->memorySlots.size(), compiled->resources.size() / 2);
        EXPECT_LT(compiled->transientBytesAliased, compiled->transientBytesUnaliased);
    }
}

TEST(RenderGraph, AliasingOnAChainNeedsTwoSlots)
{
    RenderGraph graph;
    constexpr int kLength = 10;
    auto image = [](int i) { return fmt::format("img{}", i); };
    for (int i = 0; i < kLength; ++i) declareColor(graph, image(i));
    graph.addPass("p0", QueueKind::Graphics).write(image(0), Usage::ColorAttachment);
    for (int i = 1; i < kLength; ++i)
        graph.addPass(fmt::format("p{}", i), QueueKind::Graphics)
            .read(image(i - 1), Usage::Sampled)
            .write(image(i), Usage::ColorAttachment);
    graph.markOutput(image(kLength - 1));
    const auto compiled = graph.compile();
    constexpr VkDeviceSize kImageBytes = 1024 * 1024 * 4;
    EXPECT_EQ(compiled->memorySlots.size(), 2u);
    EXPECT_EQ(compiled->transientBytesUnaliased, kLength * kImageBytes);
    EXPECT_EQ(compiled->transientBytesAliased, 2 * kImageBytes);
}

TEST(RenderGraph, VerifyAliasingRejectsOverlappingSlotMembers)
{
    RenderGraph graph;
    declareColor(graph, "a");
    declareColor(graph, "b");
    graph.addPass("p", QueueKind::Graphics).write("a", Usage::ColorAttachment).write("b", Usage::ColorAttachment);
    graph.markOutput("a");
    graph.markOutput("b");
    CompiledGraph broken = *graph.compile();
    ASSERT_EQ(broken.memorySlots.size(), 2u);
    broken.memorySlots[0].resources.push_back(broken.memorySlots[1].resources[0]);
    broken.memorySlots.pop_back();
    expectThrowContaining([&] { verifyAliasing(broken); }, {"'a'", "'b'", "overlapping"});
}

// ---------------------------------------------------------------------------------------
// Errors

TEST(RenderGraph, CycleNamesThePassesOnIt)
{
    RenderGraph graph;
    declareColor(graph, "x");
    declareColor(graph, "y");
    declareColor(graph, "z");
    graph.addPass("before", QueueKind::Graphics).write("z", Usage::ColorAttachment);
    graph.addPass("a", QueueKind::Compute).read("y", Usage::Storage).read("z", Usage::Storage).write("x", Usage::Storage);
    graph.addPass("b", QueueKind::Compute).read("x", Usage::Storage).write("y", Usage::Storage);
    graph.markOutput("x");
    expectThrowContaining([&] { graph.compile(); }, {"cycle", "'a' -> 'b' -> 'a'"});
}

TEST(RenderGraph, ReadOfAResourceNobodyWrites)
{
    RenderGraph graph;
    declareColor(graph, "history");
    declareColor(graph, "color");
    graph.addPass("taa", QueueKind::Graphics).read("history", Usage::Sampled).write("color", Usage::ColorAttachment);
    graph.markOutput("color");
    expectThrowContaining([&] { graph.compile(); }, {"'taa'", "'history'", "no pass writes"});

    RenderGraph imported;
    imported.declareImage({"history", 1024, 1024, VK_FORMAT_R8G8B8A8_UNORM, true, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL});
    declareColor(imported, "color");
    imported.addPass("taa", QueueKind::Graphics).read("history", Usage::Sampled).write("color", Usage::ColorAttachment);
    imported.markOutput("color");
    EXPECT_NO_THROW(imported.compile());

    RenderGraph modifyOnly;
    modifyOnly.declareImage({"acc", 512, 512, VK_FORMAT_R32_SFLOAT, false, {}});
    modifyOnly.addPass("accumulate", QueueKind::Compute, true).read("acc", Usage::Storage).write("acc", Usage::Storage);
    expectThrowContaining([&] { modifyOnly.compile(); }, {"'accumulate'", "'acc'", "no pass writes it first"});
}

TEST(RenderGraph, UnorderedWritersAreAmbiguous)
{
    RenderGraph graph;
    declareColor(graph, "color");
    graph.addPass("first", QueueKind::Graphics).write("color", Usage::ColorAttachment);
    graph.addPass("second", QueueKind::Graphics).write("color", Usage::ColorAttachment);
    graph.markOutput("color");
    expectThrowContaining([&] { graph.compile(); }, {"'first'", "'second'", "'color'", "no order"});
}

TEST(RenderGraph, OrderedWritersAreFine)
{
    RenderGraph graph;
    graph.declareImage({"acc", 512, 512, VK_FORMAT_R32_SFLOAT, false, {}});
    graph.addPass("clear", QueueKind::Compute).write("acc", Usage::Storage);
    graph.addPass("accumulate", QueueKind::Compute).read("acc", Usage::Storage).write("acc", Usage::Storage);
    graph.markOutput("acc");
    const auto compiled = graph.compile();
    EXPECT_EQ(passOrder(*compiled), (std::vector<std::string>{"clear", "accumulate"}));
    // Write-after-write on one image in GENERAL: a memory dependency without a transition.
    const Barrier* b = barrierFor(*compiled, "accumulate", "acc");
    ASSERT_NE(b, nullptr);
    EXPECT_EQ(b->oldLayout, VK_IMAGE_LAYOUT_GENERAL);
    EXPECT_EQ(b->newLayout, VK_IMAGE_LAYOUT_GENERAL);
    EXPECT_EQ(b->srcStage, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT);
    EXPECT_EQ(b->srcAccess, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
    EXPECT_EQ(b->dstStage, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT);
    EXPECT_EQ(b->dstAccess, VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
}

TEST(RenderGraph, MismatchedRedeclaration)
{
    RenderGraph graph;
    declareColor(graph, "shadow", 2048);
    expectThrowContaining([&] { declareColor(graph, "shadow", 1024); }, {"'shadow'", "2048x2048", "1024x1024"});
    expectThrowContaining([&] { graph.declareBuffer({"shadow", 64, false}); }, {"'shadow'", "image", "buffer"});
    graph.declareBuffer({"casters", 64, false});
    expectThrowContaining([&] { graph.declareBuffer({"casters", 128, false}); }, {"'casters'", "64", "128"});
    graph.addPass("gbuffer", QueueKind::Graphics);
    expectThrowContaining([&] { graph.addPass("gbuffer", QueueKind::Compute); }, {"'gbuffer'", "twice"});
    // An array of layers is another description; no layers is none.
    ImageDesc layered{"shadow", 2048, 2048, VK_FORMAT_R8G8B8A8_UNORM};
    layered.layers = 4;
    expectThrowContaining([&] { graph.declareImage(layered); }, {"'shadow'", "2048x2048x1", "2048x2048x4"});
    layered.name = "empty";
    layered.layers = 0;
    expectThrowContaining([&] { graph.declareImage(layered); }, {"'empty'", "layers must be > 0"});
}

TEST(RenderGraph, UndeclaredResourceAndWrongUsage)
{
    RenderGraph graph;
    declareColor(graph, "color");
    graph.addPass("shade", QueueKind::Graphics).read("visibility", Usage::Sampled).write("color", Usage::ColorAttachment);
    graph.markOutput("color");
    expectThrowContaining([&] { graph.compile(); }, {"'shade'", "'visibility'", "not declared"});

    RenderGraph wrong;
    declareColor(wrong, "color");
    wrong.addPass("blend", QueueKind::Graphics).read("color", Usage::ColorAttachment);
    wrong.addPass("draw", QueueKind::Graphics, true).write("color", Usage::ColorAttachment);
    expectThrowContaining([&] { wrong.compile(); }, {"'blend'", "'color'", "colour attachment"});
}

// ---------------------------------------------------------------------------------------
// Barriers

namespace {

struct ExpectedBarrier {
    VkImageLayout oldLayout, newLayout;
    VkPipelineStageFlags2 srcStage;
    VkAccessFlags2 srcAccess;
    VkPipelineStageFlags2 dstStage;
    VkAccessFlags2 dstAccess;
};

void expectBarrier(const CompiledGraph& compiled, const std::string& pass, const std::string& resource,
                   const ExpectedBarrier& e)
{
    SCOPED_TRACE(pass + " / " + resource);
    const Barrier* b = barrierFor(compiled, pass, resource);
    ASSERT_NE(b, nullptr);
    EXPECT_TRUE(b->isImage);
    EXPECT_EQ(b->oldLayout, e.oldLayout);
    EXPECT_EQ(b->newLayout, e.newLayout);
    EXPECT_EQ(b->srcStage, e.srcStage);
    EXPECT_EQ(b->srcAccess, e.srcAccess);
    EXPECT_EQ(b->dstStage, e.dstStage);
    EXPECT_EQ(b->dstAccess, e.dstAccess);
}

constexpr VkPipelineStageFlags2 kFragmentTests =
    VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT;
constexpr VkPipelineStageFlags2 kGraphicsShaders =
    VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT | VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT;

// G-buffer → shadow map → visibility (compute) → shading: the foundation's frame.
std::shared_ptr<const CompiledGraph> compileShadowFrame()
{
    RenderGraph graph;
    graph.declareImage({"gbuffer.normal", 1920, 1080, VK_FORMAT_R16G16B16A16_SFLOAT, false, {}});
    graph.declareImage({"gbuffer.depth", 1920, 1080, VK_FORMAT_D32_SFLOAT, false, {}});
    graph.declareImage({"shadow.depth", 2048, 2048, VK_FORMAT_D32_SFLOAT, false, {}});
    graph.declareImage({"visibility", 1920, 1080, VK_FORMAT_R16_SFLOAT, false, {}});
    graph.declareImage({"color", 1920, 1080, VK_FORMAT_R8G8B8A8_UNORM, false, {}});
    graph.addPass("gbuffer", QueueKind::Graphics)
        .write("gbuffer.normal", Usage::ColorAttachment)
        .write("gbuffer.depth", Usage::DepthAttachment);
    graph.addPass("shadowMap", QueueKind::Graphics).write("shadow.depth", Usage::DepthAttachment);
    graph.addPass("visibility", QueueKind::Compute)
        .read("gbuffer.normal", Usage::Storage)
        .read("gbuffer.depth", Usage::Sampled)
        .read("shadow.depth", Usage::Sampled)
        .write("visibility", Usage::Storage);
    graph.addPass("shade", QueueKind::Graphics)
        .read("gbuffer.normal", Usage::Sampled)
        .read("visibility", Usage::Sampled)
        .write("color", Usage::ColorAttachment);
    graph.markOutput("color");
    return graph.compile();
}

} // namespace

TEST(RenderGraph, ShadowFrameBarriers)
{
    const auto compiled = compileShadowFrame();
    ASSERT_EQ(passOrder(*compiled), (std::vector<std::string>{"gbuffer", "shadowMap", "visibility", "shade"}));

    // First use of a transient image: contents discarded, nothing to wait for.
    expectBarrier(*compiled, "gbuffer", "gbuffer.normal",
                  {VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_PIPELINE_STAGE_2_NONE,
                   VK_ACCESS_2_NONE, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                   VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT});
    // G-buffer colour write → compute storage read.
    expectBarrier(*compiled, "visibility", "gbuffer.normal",
                  {VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_GENERAL,
                   VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
                   VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_READ_BIT});
    // Shadow depth write → sampled depth read (only the write needs flushing).
    expectBarrier(*compiled, "visibility", "shadow.depth",
                  {VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL, kFragmentTests,
                   VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                   VK_ACCESS_2_SHADER_SAMPLED_READ_BIT});
    // Storage write → sampled read in the fragment shader.
    expectBarrier(*compiled, "shade", "visibility",
                  {VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL,
                   VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, kGraphicsShaders,
                   VK_ACCESS_2_SHADER_SAMPLED_READ_BIT});
    // Read after read with a layout change: wait for the earlier read, nothing to flush
    // beyond the original write.
    expectBarrier(*compiled, "shade", "gbuffer.normal",
                  {VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL,
                   VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                   VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, kGraphicsShaders, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT});
}

TEST(RenderGraph, ReadAfterReadInTheSameLayoutNeedsNoBarrier)
{
    RenderGraph graph;
    declareColor(graph, "src");
    declareColor(graph, "a");
    declareColor(graph, "b");
    graph.addPass("make", QueueKind::Graphics).write("src", Usage::ColorAttachment);
    graph.addPass("useA", QueueKind::Graphics).read("src", Usage::Sampled).write("a", Usage::ColorAttachment);
    graph.addPass("useB", QueueKind::Graphics).read("src", Usage::Sampled).write("b", Usage::ColorAttachment);
    graph.markOutput("a");
    graph.markOutput("b");
    const auto compiled = graph.compile();
    EXPECT_NE(barrierFor(*compiled, "useA", "src"), nullptr);
    EXPECT_EQ(barrierFor(*compiled, "useB", "src"), nullptr);
}

TEST(RenderGraph, AliasedImageWaitsForThePreviousOccupant)
{
    // a [0,1] and c [2,2] share a slot: c's first write must wait for the pass that last
    // read a (write-after-read) and for a's write (write-after-write on the memory).
    RenderGraph graph;
    declareColor(graph, "a");
    declareColor(graph, "b");
    declareColor(graph, "c");
    graph.addPass("p0", QueueKind::Graphics).write("a", Usage::ColorAttachment);
    graph.addPass("p1", QueueKind::Graphics).read("a", Usage::Sampled).write("b", Usage::ColorAttachment);
    graph.addPass("p2", QueueKind::Graphics).read("b", Usage::Sampled).write("c", Usage::ColorAttachment);
    graph.markOutput("c");
    const auto compiled = graph.compile();
    ASSERT_EQ(compiled->resources[0].memorySlot, compiled->resources[2].memorySlot);
    expectBarrier(*compiled, "p2", "c",
                  {VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
                   VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT | kGraphicsShaders,
                   VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                   VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT});
}

TEST(RenderGraph, BufferBarriers)
{
    RenderGraph graph;
    graph.declareBuffer({"casters", 4096, false});
    graph.declareBuffer({"draws", 256, false});
    declareColor(graph, "color");
    graph.addPass("cull", QueueKind::Compute).write("casters", Usage::Storage).write("draws", Usage::Storage);
    graph.addPass("draw", QueueKind::Graphics)
        .read("casters", Usage::VertexBuffer)
        .read("draws", Usage::IndirectBuffer)
        .write("color", Usage::ColorAttachment);
    graph.markOutput("color");
    const auto compiled = graph.compile();
    EXPECT_TRUE(passNamed(*compiled, "cull").barriersBefore.empty());
    const Barrier* indirect = barrierFor(*compiled, "draw", "draws");
    ASSERT_NE(indirect, nullptr);
    EXPECT_FALSE(indirect->isImage);
    EXPECT_EQ(indirect->srcStage, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT);
    EXPECT_EQ(indirect->srcAccess, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
    EXPECT_EQ(indirect->dstStage, VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT);
    EXPECT_EQ(indirect->dstAccess, VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT);
    const Barrier* vertex = barrierFor(*compiled, "draw", "casters");
    ASSERT_NE(vertex, nullptr);
    EXPECT_EQ(vertex->dstStage, VK_PIPELINE_STAGE_2_VERTEX_ATTRIBUTE_INPUT_BIT);
    EXPECT_EQ(vertex->dstAccess, VK_ACCESS_2_VERTEX_ATTRIBUTE_READ_BIT);
}

TEST(RenderGraph, ImportedImagesReturnToTheirInitialLayoutAfterTheFrame)
{
    RenderGraph graph;
    graph.declareImage({"history", 64, 64, VK_FORMAT_R32_SFLOAT, true, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL});
    graph.declareImage({"scratch", 64, 64, VK_FORMAT_R32_SFLOAT, true, VK_IMAGE_LAYOUT_UNDEFINED});
    graph.declareImage({"unused", 64, 64, VK_FORMAT_R32_SFLOAT, true, VK_IMAGE_LAYOUT_GENERAL});
    declareColor(graph, "color");
    graph.addPass("update", QueueKind::Compute).write("history", Usage::Storage).write("scratch", Usage::Storage);
    graph.addPass("shade", QueueKind::Graphics)
        .read("history", Usage::Sampled)
        .read("scratch", Usage::Sampled)
        .write("color", Usage::ColorAttachment);
    graph.markOutput("color");
    const auto compiled = graph.compile();
    // Ends in its initial layout: no barrier. A declared-UNDEFINED import has no state
    // to return to; an untouched import stays where it was.
    ASSERT_EQ(compiled->barriersAfter.size(), 0u);
    EXPECT_EQ(compiled->resources[0].finalLayout, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    EXPECT_EQ(compiled->resources[1].finalLayout, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    EXPECT_EQ(compiled->resources[2].finalLayout, VK_IMAGE_LAYOUT_GENERAL);
    EXPECT_EQ(compiled->resources[3].finalLayout, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL);

    RenderGraph written;
    written.declareImage({"history", 64, 64, VK_FORMAT_R32_SFLOAT, true, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL});
    written.addPass("update", QueueKind::Compute, true).write("history", Usage::Storage);
    const auto after = written.compile();
    ASSERT_EQ(after->barriersAfter.size(), 1u);
    const Barrier& restore = after->barriersAfter[0];
    EXPECT_EQ(restore.oldLayout, VK_IMAGE_LAYOUT_GENERAL);
    EXPECT_EQ(restore.newLayout, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    EXPECT_EQ(restore.srcStage, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT);
    EXPECT_EQ(restore.srcAccess, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
    EXPECT_EQ(restore.dstStage, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT);
    EXPECT_EQ(after->resources[0].finalLayout, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    EXPECT_NE(after->toText().find("after the last pass:"), std::string::npos);
}

// A read-back (RenderGraph::readBack) keeps its writers without a side effect, and after
// the last pass makes the last write visible to the host, after every pass that reads it.
TEST(RenderGraph, ReadBackKeepsItsWritersAndEndsWithABarrierToTheHost)
{
    RenderGraph graph;
    graph.declareBuffer({"counts", 64, false});
    graph.declareBuffer({"last counts", 64, true});
    graph.declareBuffer({"analysis", 64, true});
    declareColor(graph, "color");
    graph.addPass("count", QueueKind::Compute).write("counts", Usage::Storage);
    graph.addPass("copy", QueueKind::Transfer)
        .read("counts", Usage::TransferSrc)
        .write("last counts", Usage::TransferDst);
    graph.addPass("analyze", QueueKind::Compute).write("analysis", Usage::Storage);
    graph.addPass("use", QueueKind::Compute).read("analysis", Usage::Storage).write("color", Usage::Storage);
    graph.markOutput("color");

    // Nothing reads "last counts": without the read-back its writers are culled.
    EXPECT_EQ(passOrder(*graph.compile()), (std::vector<std::string>{"analyze", "use"}));
    EXPECT_TRUE(graph.compile()->barriersAfter.empty());

    graph.readBack("last counts");
    graph.readBack("analysis");
    const auto compiled = graph.compile();
    EXPECT_EQ(passOrder(*compiled), (std::vector<std::string>{"count", "copy", "analyze", "use"}));
    EXPECT_TRUE(compiled->culled.empty());
    ASSERT_EQ(compiled->barriersAfter.size(), 2u);
    for (const Barrier& b : compiled->barriersAfter) {
        const CompiledResource& res = compiled->resources[b.resource];
        SCOPED_TRACE(res.name);
        EXPECT_FALSE(b.isImage);
        EXPECT_TRUE(res.readBack);
        EXPECT_TRUE(res.hostVisible);
        EXPECT_EQ(b.dstStage, VK_PIPELINE_STAGE_2_HOST_BIT);
        EXPECT_EQ(b.dstAccess, VK_ACCESS_2_HOST_READ_BIT);
        if (res.name == "last counts") {  // the copy wrote it last
            EXPECT_EQ(b.srcStage, VK_PIPELINE_STAGE_2_TRANSFER_BIT);
            EXPECT_EQ(b.srcAccess, VK_ACCESS_2_TRANSFER_WRITE_BIT);
        } else {  // written by "analyze", then read by "use": the host waits for both
            EXPECT_EQ(res.name, "analysis");
            EXPECT_EQ(b.srcStage, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT);
            EXPECT_EQ(b.srcAccess, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
        }
    }
    EXPECT_NE(compiled->toText().find("read back"), std::string::npos);
}

TEST(RenderGraph, ReadBackOfAnUnwrittenBufferNeedsNoBarrier)
{
    RenderGraph graph;
    graph.declareBuffer({"table", 64, true});
    graph.addPass("lookup", QueueKind::Compute, true).read("table", Usage::Storage);
    graph.readBack("table");
    EXPECT_TRUE(graph.compile()->barriersAfter.empty());
}

TEST(RenderGraph, OnlyAnImportedBufferCanBeReadBack)
{
    RenderGraph graph;
    graph.declareBuffer({"transient", 64, false});
    declareColor(graph, "image");
    expectThrowContaining([&] { graph.readBack("transient"); }, {"readBack('transient')", "a transient buffer"});
    expectThrowContaining([&] { graph.readBack("image"); }, {"readBack('image')", "an image"});
    expectThrowContaining([&] { graph.readBack("missing"); }, {"readBack('missing')", "no such resource"});
}

// ---------------------------------------------------------------------------------------
// Printing

TEST(RenderGraph, TextAndDotShowPassesCulledReasonsAndSlots)
{
    RenderGraph graph;
    declareColor(graph, "color");
    declareColor(graph, "debug");
    graph.addPass("main", QueueKind::Graphics).write("color", Usage::ColorAttachment);
    graph.addPass("debugView", QueueKind::Compute).write("debug", Usage::Storage);
    graph.markOutput("color");
    const auto compiled = graph.compile();
    for (const std::string& text : {compiled->toText(), compiled->toDot()}) {
        EXPECT_NE(text.find("main"), std::string::npos) << text;
        EXPECT_NE(text.find("debugView"), std::string::npos) << text;
        EXPECT_NE(text.find("no marked output or side effect reads its outputs"), std::string::npos) << text;
        EXPECT_NE(text.find("slot 0"), std::string::npos) << text;
        EXPECT_NE(text.find("4.00 MiB"), std::string::npos) << text;
    }
    EXPECT_EQ(compiled->toDot().rfind("digraph", 0), 0u);
}
