// The adaptive shadow map's quadtree bookkeeping (plugins/adaptive-sm/tile_tree.h), on
// the CPU: base levels, refinement by benefit within the budget, the memory limit with
// LRU eviction of leaves (children before parents), replacement only for a greater
// benefit, invalidation of the cells a box touches, and a random walk that keeps the tree
// consistent within its slots.
#include "tile_tree.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <set>
#include <stdexcept>
#include <vector>

using namespace penumbra::adaptive_sm;

namespace {

// An analysis in which `slot`'s quadrant `q` asks with `benefit` and the slots in `used`
// were used.
std::vector<NodeAnalysis> analysisFor(const TileTree& tree, std::vector<uint32_t> used = {})
{
    std::vector<NodeAnalysis> a(tree.slots());
    for (uint32_t s : used) a[s].used = 1;
    return a;
}

void ask(std::vector<NodeAnalysis>& a, uint32_t slot, uint32_t quadrant, uint32_t benefit)
{
    a[slot].used = std::max(a[slot].used, 1u);
    a[slot].benefit[quadrant] = benefit;
}

// Every resident node is reachable from the root once, its parent's child at its
// quadrant, one level deeper, in the parent's cell; free slots are unreachable.
void expectConsistent(const TileTree& tree)
{
    const auto& t = tree.table();
    std::set<uint32_t> reached;
    std::vector<uint32_t> stack;
    for (uint32_t f = 0; f < tree.faces(); ++f) {
        EXPECT_EQ(t[f].face, f);
        EXPECT_EQ(t[f].level, 0u);
        stack.push_back(f);
    }
    while (!stack.empty()) {
        const uint32_t s = stack.back();
        stack.pop_back();
        ASSERT_TRUE(t[s].resident()) << "slot " << s;
        ASSERT_TRUE(reached.insert(s).second) << "slot " << s << " reached twice";
        for (uint32_t q = 0; q < 4; ++q) {
            const int32_t c = t[s].children[q];
            if (c == kNoNode) continue;
            ASSERT_LT(uint32_t(c), tree.slots());
            EXPECT_EQ(t[uint32_t(c)].level, t[s].level + 1);
            EXPECT_EQ(t[uint32_t(c)].face, t[s].face);
            EXPECT_EQ(t[uint32_t(c)].x, 2 * t[s].x + (q & 1));
            EXPECT_EQ(t[uint32_t(c)].y, 2 * t[s].y + (q >> 1));
            stack.push_back(uint32_t(c));
        }
    }
    uint32_t resident = 0;
    for (const GpuNode& n : t) resident += n.resident() ? 1 : 0;
    EXPECT_EQ(reached.size(), resident);
    EXPECT_EQ(tree.resident(), resident);
    EXPECT_LE(resident, tree.slots());
}

} // namespace

TEST(AsmTileTree, BaseLevelsAreResidentAndDrawnFirst)
{
    TileTree tree(32, 2, 8);
    EXPECT_EQ(tree.resident(), 21u);  // 1 + 4 + 16
    expectConsistent(tree);
    std::vector<uint32_t> pending = tree.takePending();
    EXPECT_EQ(pending.size(), 21u);
    EXPECT_EQ(pending.front(), 0u);  // the root first, parents before children
    EXPECT_TRUE(tree.takePending().empty());
    EXPECT_EQ(tree.deepestLevel(), 2u);
    EXPECT_THROW(TileTree(20, 2, 8), std::invalid_argument);  // 21 tiles do not fit
    EXPECT_THROW(TileTree(64, 3, 2), std::invalid_argument);
    EXPECT_THROW(TileTree(64, 0, kMaxLevels), std::invalid_argument);
}

TEST(AsmTileTree, RefinesTheMostProfitableCellsWithinTheBudget)
{
    TileTree tree(64, 1, 8);
    tree.takePending();
    std::vector<NodeAnalysis> a = analysisFor(tree);
    ask(a, 1, 0, 5);
    ask(a, 2, 3, 50);
    ask(a, 3, 1, 20);
    ask(a, 4, 2, 0);  // used, asks nothing
    tree.recordAnalysis(a, 1);
    // Two tiles fit in the budget: the two largest benefits.
    RefineStep step = tree.refine({10.0, 4.0, 1});
    ASSERT_EQ(step.created.size(), 2u);
    EXPECT_EQ(step.candidates, 3u);
    EXPECT_EQ(step.deferred, 1u);
    EXPECT_EQ(tree.table()[2].children[3], int32_t(step.created[0]));
    EXPECT_EQ(tree.table()[3].children[1], int32_t(step.created[1]));
    EXPECT_EQ(tree.table()[1].children[0], kNoNode);
    EXPECT_EQ(tree.takePending(), step.created);
    expectConsistent(tree);
    // A tile dearer than the whole budget: still one per step, so refinement never stalls.
    step = tree.refine({1.0, 4.0, 1});
    EXPECT_EQ(step.created.size(), 1u);
    EXPECT_EQ(tree.table()[1].children[0], int32_t(step.created[0]));
    // min_benefit: a cell below it asks for nothing.
    tree.recordAnalysis(a, 2);
    EXPECT_TRUE(tree.refine({100.0, 1.0, 100}).created.empty());
    EXPECT_FALSE(tree.wantsMore(100));
}

TEST(AsmTileTree, EvictsTheLeastRecentlyUsedLeavesChildrenBeforeParents)
{
    // The base (5 tiles) and 3 more.
    TileTree tree(8, 1, 8);
    std::vector<NodeAnalysis> a = analysisFor(tree);
    ask(a, 1, 0, 9);
    tree.recordAnalysis(a, 1);
    const uint32_t child = tree.refine({100.0, 1.0, 1}).created.at(0);  // level 2 under slot 1
    a = analysisFor(tree);
    ask(a, child, 0, 9);
    tree.recordAnalysis(a, 2);
    const uint32_t grandchild = tree.refine({100.0, 1.0, 1}).created.at(0);  // level 3
    a = analysisFor(tree);
    ask(a, 2, 0, 9);
    tree.recordAnalysis(a, 3);
    const uint32_t other = tree.refine({100.0, 1.0, 1}).created.at(0);  // the last free slot
    EXPECT_EQ(tree.resident(), 8u);
    expectConsistent(tree);

    // Frame 4 uses only slot 3's cell, which asks twice. The least recently used leaves
    // go: the grandchild (last used in frame 2), then its parent, a leaf once the
    // grandchild is gone (frame 2), before `other` (made in frame 3).
    a = analysisFor(tree);
    ask(a, 3, 0, 7);
    ask(a, 3, 1, 6);
    tree.recordAnalysis(a, 4);
    const uint64_t before = tree.totalEvictions();
    RefineStep step = tree.refine({100.0, 1.0, 1});
    ASSERT_EQ(step.created.size(), 2u);
    EXPECT_EQ(step.evicted, 2u);
    EXPECT_EQ(tree.totalEvictions(), before + 2);
    EXPECT_EQ(tree.table()[1].children[0], kNoNode);
    EXPECT_TRUE(tree.table()[other].resident());
    EXPECT_EQ(tree.table()[2].children[0], int32_t(other));
    std::set<uint32_t> reused(step.created.begin(), step.created.end());
    EXPECT_EQ(reused, (std::set<uint32_t>{child, grandchild}));
    expectConsistent(tree);
}

TEST(AsmTileTree, ReplacesANodeInUseOnlyForAGreaterBenefit)
{
    TileTree tree(6, 1, 8);
    std::vector<NodeAnalysis> a = analysisFor(tree);
    ask(a, 1, 0, 9);
    tree.recordAnalysis(a, 1);
    const uint32_t leaf = tree.refine({100.0, 1.0, 1}).created.at(0);
    EXPECT_EQ(tree.resident(), 6u);  // full
    // Everything is in use; the leaf serves 10 edge pixels. A cell asking with 10 is not
    // enough, 11 is.
    a = analysisFor(tree, {0, 1, 2, 3, 4});
    a[leaf].used = 20;
    a[leaf].edges = 10;
    ask(a, 2, 0, 10);
    tree.recordAnalysis(a, 2);
    EXPECT_FALSE(tree.wantsMore(1));
    RefineStep step = tree.refine({100.0, 1.0, 1});
    EXPECT_TRUE(step.created.empty());
    EXPECT_EQ(step.deferred, 1u);
    EXPECT_EQ(tree.table()[1].children[0], int32_t(leaf));
    ask(a, 2, 0, 11);
    tree.recordAnalysis(a, 3);
    EXPECT_TRUE(tree.wantsMore(1));
    step = tree.refine({100.0, 1.0, 1});
    ASSERT_EQ(step.created.size(), 1u);
    EXPECT_EQ(step.evicted, 1u);
    EXPECT_EQ(tree.table()[1].children[0], kNoNode);
    EXPECT_EQ(tree.table()[2].children[0], int32_t(step.created[0]));
    // Base nodes are never removed, even unused.
    for (uint32_t s = 0; s < 5; ++s) EXPECT_TRUE(tree.table()[s].resident());
    expectConsistent(tree);
}

TEST(AsmTileTree, InvalidatesOnlyTheCellsABoxTouches)
{
    TileTree tree(64, 2, 8);
    tree.takePending();
    // A box inside the level-2 cell (1, 2): uv [0.25, 0.5) x [0.5, 0.75).
    const uint32_t hit = tree.invalidate(0, 0.3f, 0.55f, 0.4f, 0.7f);
    std::vector<uint32_t> pending = tree.takePending();
    EXPECT_EQ(hit, 3u);  // the root, its quadrant 2 and the level-2 cell
    ASSERT_EQ(pending.size(), 3u);
    for (uint32_t s : pending) {
        const GpuNode& n = tree.table()[s];
        const float size = 1.0f / float(1u << n.level);
        EXPECT_TRUE(n.x * size <= 0.4f && (n.x + 1) * size >= 0.3f && n.y * size <= 0.7f && (n.y + 1) * size >= 0.55f);
    }
    // Over the whole view: every node.
    EXPECT_EQ(tree.invalidate(0, 0.0f, 0.0f, 1.0f, 1.0f), 21u);
}

TEST(AsmTileTree, BottomUpOrderListsTheDeepestLevelFirst)
{
    TileTree tree(64, 1, 4);
    std::vector<NodeAnalysis> a = analysisFor(tree);
    ask(a, 1, 2, 3);
    tree.recordAnalysis(a, 1);
    tree.refine({100.0, 1.0, 1});
    std::vector<uint32_t> order;
    std::array<uint32_t, kMaxLevels + 1> start{};
    tree.bottomUpOrder(order, start);
    ASSERT_EQ(order.size(), 6u);
    uint32_t previous = 99;
    for (uint32_t i = 0; i < kMaxLevels; ++i)
        for (uint32_t k = start[i]; k < start[i + 1]; ++k) {
            EXPECT_EQ(tree.table()[order[k]].level, 4u - i);
            EXPECT_LE(tree.table()[order[k]].level, previous);
            previous = tree.table()[order[k]].level;
        }
    EXPECT_EQ(start[kMaxLevels], 6u);
    EXPECT_EQ(order.back(), 0u);  // the root last
}

// Six cube faces: six roots in slots 0 .. 5, each with its own base levels; a box on one
// face invalidates that face's cells only.
TEST(AsmTileTree, CubeFacesHaveATreeEach)
{
    EXPECT_THROW(TileTree(29, 1, 8, 6), std::invalid_argument);  // 6 x 5 tiles
    TileTree tree(64, 1, 8, 6);
    EXPECT_EQ(tree.resident(), 30u);
    expectConsistent(tree);
    tree.takePending();
    EXPECT_EQ(tree.invalidate(4, 0.0f, 0.0f, 1.0f, 1.0f), 5u);
    for (uint32_t s : tree.takePending()) EXPECT_EQ(tree.table()[s].face, 4u);
    // A child of face 3's quadrant 1 is face 3's.
    std::vector<NodeAnalysis> a(tree.slots());
    const int32_t q1 = tree.table()[3].children[1];
    ask(a, uint32_t(q1), 2, 5);
    tree.recordAnalysis(a, 1);
    const RefineStep step = tree.refine({10.0, 1.0, 1});
    ASSERT_EQ(step.created.size(), 1u);
    EXPECT_EQ(tree.table()[step.created[0]].face, 3u);
    EXPECT_EQ(tree.table()[step.created[0]].level, 2u);
    expectConsistent(tree);
}

// The page table: each cell of its level names the finest node holding all of it.
TEST(AsmTileTree, PageTableNamesTheFinestNodeOverEachCell)
{
    TileTree tree(64, 1, 8, 2);
    std::vector<NodeAnalysis> a(tree.slots());
    const int32_t q3 = tree.table()[1].children[3];  // face 1, level 1, cell (1, 1)
    ask(a, uint32_t(q3), 0, 5);
    tree.recordAnalysis(a, 1);
    const uint32_t deep = tree.refine({10.0, 1.0, 1}).created.at(0);  // face 1, level 2, cell (2, 2)
    std::vector<int32_t> pages;
    tree.pageTable(3, pages);  // 8 x 8 cells a face
    ASSERT_EQ(pages.size(), 2u * 64u);
    for (uint32_t f = 0; f < 2; ++f)
        for (uint32_t cy = 0; cy < 8; ++cy)
            for (uint32_t cx = 0; cx < 8; ++cx) {
                const GpuNode& n = tree.table()[uint32_t(pages[f * 64 + cy * 8 + cx])];
                EXPECT_EQ(n.face, f);
                // The node's cell holds the page cell, and no child of it does.
                EXPECT_EQ(cx >> (3 - n.level), n.x);
                EXPECT_EQ(cy >> (3 - n.level), n.y);
                const bool inDeep = f == 1 && cx / 2 == 2 && cy / 2 == 2;
                EXPECT_EQ(n.level, inDeep ? 2u : 1u);
                if (inDeep) {
                    EXPECT_EQ(uint32_t(pages[f * 64 + cy * 8 + cx]), deep);
                }
            }
}

// Random analyses over many steps: the tree stays consistent, within its slots, and never
// drops a base node.
TEST(AsmTileTree, StaysConsistentWithinItsSlotsOverRandomSteps)
{
    for (uint32_t slots : {5u, 9u, 30u, 100u}) {
        SCOPED_TRACE(slots);
        TileTree tree(slots, 1, 6);
        std::mt19937 rng(slots);
        for (uint64_t frame = 1; frame <= 200; ++frame) {
            std::vector<NodeAnalysis> a(tree.slots());
            for (uint32_t s = 0; s < tree.slots(); ++s) {
                if (!tree.table()[s].resident() || rng() % 3 == 0) continue;
                a[s].used = 1 + rng() % 50;
                a[s].edges = rng() % (a[s].used + 1);
                for (uint32_t q = 0; q < 4; ++q) a[s].benefit[q] = rng() % 4 == 0 ? rng() % 40 : 0;
            }
            tree.recordAnalysis(a, frame);
            const RefineStep step = tree.refine({double(rng() % 5), 1.0, 1});
            EXPECT_LE(step.created.size(), 5u);
            expectConsistent(tree);
            for (uint32_t s = 0; s < 5; ++s) ASSERT_TRUE(tree.table()[s].resident() && tree.table()[s].level <= 1);
            if (frame % 50 == 0) tree.reset();
        }
    }
}
