// render::DrawBatches (engine/src/render/DrawBatches.h, private to the engine): how
// SceneGpu groups instances into instanced, indirect multi-draws. No device needed.
#include "engine/src/render/DrawBatches.h"

#include "penumbra/core/Error.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

namespace penumbra::render {
namespace {

// The instances a batch draws, sorted, from its commands (firstInstance + i is a slot).
std::vector<uint32_t> drawnInstances(const DrawBatches& batches, const DrawBatch& batch)
{
    std::vector<uint32_t> out;
    for (const VkDrawIndexedIndirectCommand& c : batch.commands)
        for (uint32_t i = 0; i < c.instanceCount; ++i) out.push_back(batches.slotInstances()[c.firstInstance + i]);
    std::sort(out.begin(), out.end());
    return out;
}

// Every command draws one mesh's range, and its instances are all of that mesh.
void expectCommandsMatchMeshes(const DrawBatches& batches, const DrawBatch& batch,
                               const std::vector<uint32_t>& instanceMesh, const std::vector<MeshRange>& meshes)
{
    for (const VkDrawIndexedIndirectCommand& c : batch.commands) {
        ASSERT_GT(c.instanceCount, 0u);
        for (uint32_t i = 0; i < c.instanceCount; ++i) {
            const MeshRange& m = meshes[instanceMesh[batches.slotInstances()[c.firstInstance + i]]];
            EXPECT_EQ(c.indexCount, m.indexCount);
            EXPECT_EQ(c.firstIndex, m.firstIndex);
            EXPECT_EQ(c.vertexOffset, m.vertexOffset);
        }
    }
}

// Meshes: 0 solid on texture 5, 1 alpha-masked on texture 2, 2 solid on texture 5,
// 3 without triangles.
const std::vector<MeshRange> kMeshes = {
    {36, 0, 0, 5, false, false}, {6, 36, 24, 2, true, true}, {12, 42, 28, 5, false, true}, {0, 54, 36, 5, false, false}};
// Mesh 1 is alpha-masked, mesh 2 translucent (BLEND): both see-through.
// Instances 0..7 of meshes:
const std::vector<uint32_t> kInstanceMesh = {0, 1, 2, 0, 2, 0, 3, 1};

TEST(DrawBatches, SlotsOrderInstancesByTextureThenMeshThenInstance)
{
    const DrawBatches batches(kInstanceMesh, kMeshes, false);
    // Texture 2: mesh 1 (instances 1, 7); texture 5: mesh 0 (0, 3, 5), mesh 2 (2, 4).
    const std::vector<uint32_t> expected = {1, 7, 0, 3, 5, 2, 4};
    EXPECT_EQ(std::vector<uint32_t>(batches.slotInstances().begin(), batches.slotInstances().end()), expected);
    EXPECT_EQ(batches.slotOf(6), DrawBatches::kNoSlot);
    EXPECT_EQ(batches.slotOf(5), 4u);
    EXPECT_TRUE(batches.isAlphaMasked(7));
    EXPECT_FALSE(batches.isAlphaMasked(4));
    EXPECT_TRUE(batches.hasAlphaMasked());
    EXPECT_THROW(batches.slotOf(8), Error);
}

TEST(DrawBatches, OneInstancedCommandPerMeshAndOneGroupPerTexture)
{
    const DrawBatches batches(kInstanceMesh, kMeshes, false);
    DrawBatch b;
    batches.build(DrawFilter::All, nullptr, true, b);
    ASSERT_EQ(b.commands.size(), 3u);
    ASSERT_EQ(b.groups.size(), 2u);
    EXPECT_EQ(b.groups[0].texture, 2u);
    EXPECT_EQ(b.groups[0].commandCount, 1u);
    EXPECT_EQ(b.groups[1].texture, 5u);
    EXPECT_EQ(b.groups[1].firstCommand, 1u);
    EXPECT_EQ(b.groups[1].commandCount, 2u);
    EXPECT_EQ(b.commands[1].instanceCount, 3u);
    EXPECT_EQ(b.commands[1].firstInstance, 2u);
    EXPECT_EQ(b.counts.instances, 7u);
    EXPECT_EQ(b.counts.triangles, 2u * 2 + 3u * 12 + 2u * 4);
    expectCommandsMatchMeshes(batches, b, kInstanceMesh, kMeshes);

    // Without texture binding every texture's commands are one group.
    batches.build(DrawFilter::All, nullptr, false, b);
    ASSERT_EQ(b.groups.size(), 1u);
    EXPECT_EQ(b.groups[0].commandCount, 3u);
}

TEST(DrawBatches, FiltersSplitSolidFromAlphaMasked)
{
    const DrawBatches batches(kInstanceMesh, kMeshes, false);
    DrawBatch b;
    batches.build(DrawFilter::Solid, nullptr, true, b);
    EXPECT_EQ(drawnInstances(batches, b), (std::vector<uint32_t>{0, 2, 3, 4, 5}));
    ASSERT_EQ(b.groups.size(), 1u);
    EXPECT_EQ(b.groups[0].texture, 5u);
    batches.build(DrawFilter::AlphaMasked, nullptr, true, b);
    EXPECT_EQ(drawnInstances(batches, b), (std::vector<uint32_t>{1, 7}));
    ASSERT_EQ(b.groups.size(), 1u);
    EXPECT_EQ(b.groups[0].texture, 2u);
    EXPECT_EQ(b.counts.instances, 2u);
    EXPECT_EQ(b.counts.triangles, 4u);
}

TEST(DrawBatches, AMaskSplitsAMeshIntoRunsOfDrawnInstances)
{
    const DrawBatches batches(kInstanceMesh, kMeshes, false);
    std::vector<uint8_t> mask(8, 0);
    for (const uint32_t i : {0u, 5u, 2u, 1u, 6u}) mask[i] = 1;
    DrawBatch b;
    batches.build(DrawFilter::All, &mask, true, b);
    // Mesh 0's slots hold instances 0, 3, 5: instance 3 is masked out, so two runs.
    EXPECT_EQ(drawnInstances(batches, b), (std::vector<uint32_t>{0, 1, 2, 5}));
    EXPECT_EQ(b.commands.size(), 4u);
    EXPECT_EQ(b.counts.instances, 4u);
    EXPECT_EQ(b.counts.triangles, 2u + 12u + 12u + 4u);
    // A group with every instance masked out does not exist.
    std::fill(mask.begin(), mask.end(), 0);
    mask[3] = 1;
    batches.build(DrawFilter::All, &mask, true, b);
    ASSERT_EQ(b.groups.size(), 1u);
    EXPECT_EQ(b.groups[0].texture, 5u);
    const std::vector<uint8_t> tooShort(7, 1);
    EXPECT_THROW(batches.build(DrawFilter::All, &tooShort, true, b), Error);
}

TEST(DrawBatches, DrawInstancesMergesConsecutiveSlotsOfOneMesh)
{
    const DrawBatches batches(kInstanceMesh, kMeshes, false);
    DrawBatch b;
    const std::vector<uint32_t> list = {5, 0, 6, 1, 3, 4};
    batches.buildInstances(list, false, b);
    // Opaque: 5, 0, 3 are mesh 0's slots 4, 2, 3 (one run).
    EXPECT_EQ(drawnInstances(batches, b), (std::vector<uint32_t>{0, 3, 5}));
    ASSERT_EQ(b.commands.size(), 1u);
    EXPECT_EQ(b.commands[0].instanceCount, 3u);
    EXPECT_EQ(b.groups.size(), 1u);
    // See-through: the alpha-masked 1 and the translucent 4 (never occluders).
    batches.buildInstances(list, true, b);
    EXPECT_EQ(drawnInstances(batches, b), (std::vector<uint32_t>{1, 4}));
    // A repeated instance is drawn again, as one draw per listed instance would.
    batches.buildInstances(std::vector<uint32_t>{0, 0}, false, b);
    EXPECT_EQ(b.counts.instances, 2u);
    EXPECT_EQ(b.commands.size(), 2u);
    EXPECT_THROW(batches.buildInstances(std::vector<uint32_t>{9}, false, b), Error);
}

// Random scenes and masks: batched and per-instance draws select exactly the instances
// that one draw per instance would, with its counts; per-instance has one command each.
TEST(DrawBatches, RandomMasksDrawExactlyTheSelectedInstances)
{
    std::mt19937 rng(18);
    for (int round = 0; round < 50; ++round) {
        std::vector<MeshRange> meshes;
        const uint32_t meshCount = 1 + rng() % 6;
        for (uint32_t m = 0; m < meshCount; ++m)
            meshes.push_back({uint32_t(3 * (rng() % 4)), 100 * m, int32_t(50 * m), uint32_t(rng() % 3), rng() % 3 == 0});
        std::vector<uint32_t> instanceMesh(1 + rng() % 40);
        for (uint32_t& m : instanceMesh) m = rng() % meshCount;
        std::vector<uint8_t> mask(instanceMesh.size());
        for (uint8_t& v : mask) v = rng() % 2;
        for (const DrawFilter filter : {DrawFilter::All, DrawFilter::Solid, DrawFilter::AlphaMasked}) {
            std::vector<uint32_t> expected;
            uint64_t triangles = 0;
            for (uint32_t i = 0; i < instanceMesh.size(); ++i) {
                const MeshRange& m = meshes[instanceMesh[i]];
                if (m.indexCount == 0 || !mask[i]) continue;
                if ((filter == DrawFilter::Solid && m.alphaMasked) || (filter == DrawFilter::AlphaMasked && !m.alphaMasked))
                    continue;
                expected.push_back(i);
                triangles += m.indexCount / 3;
            }
            for (const bool perInstance : {false, true}) {
                const DrawBatches batches(instanceMesh, meshes, perInstance);
                DrawBatch b;
                batches.build(filter, &mask, true, b);
                EXPECT_EQ(drawnInstances(batches, b), expected);
                EXPECT_EQ(b.counts.instances, expected.size());
                EXPECT_EQ(b.counts.triangles, triangles);
                expectCommandsMatchMeshes(batches, b, instanceMesh, meshes);
                uint32_t grouped = 0;
                for (size_t g = 0; g < b.groups.size(); ++g) {
                    EXPECT_GT(b.groups[g].commandCount, 0u);
                    EXPECT_EQ(b.groups[g].firstCommand, grouped);
                    if (g > 0) {
                        EXPECT_NE(b.groups[g].texture, b.groups[g - 1].texture);
                    }
                    grouped += b.groups[g].commandCount;
                }
                EXPECT_EQ(grouped, b.commands.size());
                if (perInstance) {
                    EXPECT_EQ(b.commands.size(), expected.size());
                } else {
                    EXPECT_LE(b.commands.size(), expected.size());
                }
            }
        }
    }
}

} // namespace
} // namespace penumbra::render
