#pragma once
// The adaptive shadow map's quadtree on the CPU (Fernando 2002, thesis ch. 2, "Data
// structure", "Creating nodes", "Removing nodes"): which tiles of the light view are
// resident, in which atlas slot, which to create next and which to remove. No Vulkan: the
// technique (adaptive_sm.cpp) feeds it the GPU analysis of the last frame and uploads
// its table (asm_tree.glsl reads it).
//
// One quadtree per light view (face): one for spot and directional lights, six for the
// cube faces of point, rect and disk lights; face f's root is slot f. A node of face f at
// level L, cell (x, y) covers [x, x + 1) / 2^L x [y, y + 1) / 2^L of that face's uv square
// and holds one tile of tile x tile depth texels; its four cells (quadrant q = qx + 2 qy)
// may each hold a child at level L + 1. Node index = atlas slot: the trees never hold more
// nodes than the atlas has slots, which is how the memory budget is honoured exactly.
// Levels 0 .. baseLevel are always resident (the thesis' starting map, 512² in its
// walkthrough).
#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace penumbra::adaptive_sm {

inline constexpr int32_t kNoNode = -1;
inline constexpr uint32_t kMaxLevels = 16;  // levels 0 .. 15: 2^15 tiles across
inline constexpr uint32_t kFreeSlot = 0xffffffffu;  // GpuNode::face of a slot that holds no node

// One node as the shaders read it (std430; asm_tree.glsl AsmNode).
struct GpuNode {
    std::array<int32_t, 4> children{kNoNode, kNoNode, kNoNode, kNoNode};  // slot per quadrant, or -1
    uint32_t level = 0;
    uint32_t x = 0;
    uint32_t y = 0;
    uint32_t face = kFreeSlot;  // the light view (cube face) it belongs to; kFreeSlot: no node
    bool resident() const { return face != kFreeSlot; }
};
static_assert(sizeof(GpuNode) == 32);

// What the analysis found for one node in the last analyzed frame (std430; asm_tree.glsl
// AsmAnalysis): the sampled eye pixels whose lookup ends at the node, those of them on a
// shadow edge at its resolution, and per quadrant the pixels that would gain from a child
// there (an edge, and a texel larger than the pixel: the benefit).
struct NodeAnalysis {
    uint32_t used = 0;
    uint32_t edges = 0;
    std::array<uint32_t, 4> benefit{};
};
static_assert(sizeof(NodeAnalysis) == 24);

// How one refinement step may spend time and what it counts as worth a tile.
struct RefineBudget {
    double budgetMs = 0.0;    // refine_ms
    double tileCostMs = 0.0;  // a N + b for one tile (calibrated)
    uint32_t minBenefit = 1;  // sampled pixels a new node must serve at least
};

// What one refinement step did.
struct RefineStep {
    std::vector<uint32_t> created;  // new nodes (slots), in creation order: render their tiles
    uint32_t evicted = 0;           // nodes removed for them
    uint32_t candidates = 0;        // cells that asked for a child
    uint32_t deferred = 0;          // cells left for later steps (time budget or memory)
};

class TileTree {
public:
    // `slots`: tiles the atlas holds; `faces`: 1 or 6 light views. Throws
    // std::invalid_argument when levels 0 .. baseLevel of every face do not fit in the slots
    // or maxLevel is out of [baseLevel, kMaxLevels).
    TileTree(uint32_t slots, uint32_t baseLevel, uint32_t maxLevel, uint32_t faces = 1);

    // Forgets every node above the base levels and marks the base for rendering (the
    // light moved, or the first frame).
    void reset();

    // The last analyzed frame's counts, one per slot (asm analysis buffer): nodes whose
    // lookups ended there, and their ancestors, were used in frame `frame`.
    void recordAnalysis(std::span<const NodeAnalysis> analysis, uint64_t frame);

    // Creates the most profitable children (benefit per cost, highest first) while the
    // budget lasts, at least one when any cell asks (so that progress never stops when a
    // tile costs more than the budget); a new node takes a free slot, else the least
    // recently used leaf not used in the last analyzed frame (children go before their
    // parents: only leaves are removed), else, when every node is in use, the in-use leaf
    // that serves the fewest edge pixels, and only when the new node's benefit is greater.
    RefineStep refine(const RefineBudget& budget);

    // Marks every resident node of `face` whose cell overlaps the uv rectangle [lo, hi] for
    // rendering again (a caster moved there). Returns how many.
    uint32_t invalidate(uint32_t face, float loU, float loV, float hiU, float hiV);
    // Nodes to render this frame (created or invalidated), and clears the list.
    std::vector<uint32_t> takePending();

    // The table the shaders walk (index = slot; face f's root is slot f).
    const std::vector<GpuNode>& table() const { return table_; }
    // Resident nodes, deepest level first (the order in which subtree depth ranges are
    // combined bottom-up), and where each level starts in that list (levelStart[l] ..
    // levelStart[l + 1] hold level maxLevel - l).
    void bottomUpOrder(std::vector<uint32_t>& order, std::array<uint32_t, kMaxLevels + 1>& levelStart) const;

    // The page table the shaders start their walks from (asm_tree.glsl AsmPages): per face,
    // for each cell of level `level` (row-major, 2^level across), the finest resident node
    // whose cell holds that whole cell.
    void pageTable(uint32_t level, std::vector<int32_t>& pages) const;

    uint32_t slots() const { return uint32_t(table_.size()); }
    uint32_t faces() const { return faces_; }
    // Changes whenever a node is created or removed: tables derived from the tree (the
    // page table) need rebuilding only then.
    uint64_t version() const { return version_; }
    uint32_t resident() const { return resident_; }
    uint32_t deepestLevel() const;
    uint32_t baseLevel() const { return baseLevel_; }
    uint32_t maxLevel() const { return maxLevel_; }
    uint64_t totalEvictions() const { return totalEvictions_; }
    // Whether the last analysis asked for a child anywhere that memory could still grant
    // (a free slot, a node unused in the last frame, or a weaker leaf): a still view would
    // improve with another step.
    bool wantsMore(uint32_t minBenefit) const;

private:
    struct Node {
        int32_t parent = kNoNode;
        uint64_t lastUsed = 0;
        uint32_t edges = 0;                 // last analysis
        std::array<uint32_t, 4> benefit{};  // last analysis
    };
    uint32_t create(int32_t parent, uint32_t quadrant, uint32_t slot);
    void remove(uint32_t slot);
    bool isLeaf(uint32_t slot) const;
    int32_t leastRecentlyUsedLeaf(uint64_t before) const;
    int32_t weakestLeaf(int32_t keepAncestorsOf) const;

    uint32_t baseLevel_ = 0;
    uint32_t maxLevel_ = 0;
    uint32_t faces_ = 1;
    std::vector<GpuNode> table_;
    std::vector<Node> nodes_;
    std::vector<uint32_t> free_;  // free slots, taken from the back
    std::vector<uint32_t> pending_;
    uint32_t resident_ = 0;
    uint64_t lastAnalyzed_ = 0;
    uint64_t totalEvictions_ = 0;
    uint64_t version_ = 0;
};

} // namespace penumbra::adaptive_sm
