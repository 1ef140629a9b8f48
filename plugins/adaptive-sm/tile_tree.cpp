#include "tile_tree.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace penumbra::adaptive_sm {
namespace {

uint32_t nodesUpToLevel(uint32_t level)
{
    uint64_t n = 0;
    for (uint32_t l = 0; l <= level; ++l) n += uint64_t(1) << (2 * l);
    return uint32_t(std::min<uint64_t>(n, std::numeric_limits<uint32_t>::max()));
}

// A new node has not been analyzed yet: it counts as serving every pixel, so that the
// step that made it never removes it for another.
constexpr uint32_t kUnanalyzed = std::numeric_limits<uint32_t>::max();

} // namespace

TileTree::TileTree(uint32_t slots, uint32_t baseLevel, uint32_t maxLevel, uint32_t faces)
    : baseLevel_(baseLevel), maxLevel_(maxLevel), faces_(faces)
{
    if (maxLevel >= kMaxLevels || baseLevel > maxLevel)
        throw std::invalid_argument("levels: base " + std::to_string(baseLevel) + " and max " +
                                    std::to_string(maxLevel) + " must satisfy base <= max < " + std::to_string(kMaxLevels));
    if (faces == 0 || uint64_t(faces) * nodesUpToLevel(baseLevel) > slots)
        throw std::invalid_argument("levels 0 .. " + std::to_string(baseLevel) + " of " + std::to_string(faces) +
                                    " light view(s) take " + std::to_string(uint64_t(faces) * nodesUpToLevel(baseLevel)) +
                                    " tiles, the atlas holds " + std::to_string(slots));
    table_.resize(slots);
    nodes_.resize(slots);
    reset();
}

void TileTree::reset()
{
    ++version_;
    std::fill(table_.begin(), table_.end(), GpuNode{});
    std::fill(nodes_.begin(), nodes_.end(), Node{});
    free_.clear();
    for (uint32_t s = slots(); s-- > 0;) free_.push_back(s);  // slot 0 first
    pending_.clear();
    resident_ = 0;
    // The roots (slot f for face f), then level by level, so that every parent exists
    // before its children.
    std::vector<uint32_t> level;
    for (uint32_t f = 0; f < faces_; ++f) {
        const uint32_t root = free_.back();
        free_.pop_back();
        table_[root] = GpuNode{};
        table_[root].face = f;
        nodes_[root].lastUsed = lastAnalyzed_;
        nodes_[root].edges = kUnanalyzed;
        ++resident_;
        pending_.push_back(root);
        level.push_back(root);
    }
    for (uint32_t l = 0; l < baseLevel_; ++l) {
        std::vector<uint32_t> next;
        for (uint32_t parent : level)
            for (uint32_t q = 0; q < 4; ++q) {
                const uint32_t slot = free_.back();
                free_.pop_back();
                next.push_back(create(int32_t(parent), q, slot));
            }
        level = std::move(next);
    }
}

uint32_t TileTree::create(int32_t parent, uint32_t quadrant, uint32_t slot)
{
    const GpuNode& p = table_[uint32_t(parent)];
    GpuNode& n = table_[slot];
    n = GpuNode{};
    n.level = p.level + 1;
    n.x = 2 * p.x + (quadrant & 1u);
    n.y = 2 * p.y + (quadrant >> 1);
    n.face = p.face;
    table_[uint32_t(parent)].children[quadrant] = int32_t(slot);
    ++version_;
    nodes_[slot] = Node{parent, lastAnalyzed_, kUnanalyzed, {}};
    ++resident_;
    pending_.push_back(slot);
    return slot;
}

void TileTree::remove(uint32_t slot)
{
    const int32_t parent = nodes_[slot].parent;
    if (parent != kNoNode)
        for (int32_t& child : table_[uint32_t(parent)].children)
            if (child == int32_t(slot)) child = kNoNode;
    table_[slot] = GpuNode{};
    nodes_[slot] = Node{};
    free_.push_back(slot);
    std::erase(pending_, slot);
    --resident_;
    ++totalEvictions_;
    ++version_;
}

bool TileTree::isLeaf(uint32_t slot) const
{
    return std::ranges::all_of(table_[slot].children, [](int32_t c) { return c == kNoNode; });
}

void TileTree::recordAnalysis(std::span<const NodeAnalysis> analysis, uint64_t frame)
{
    lastAnalyzed_ = frame;
    const size_t n = std::min(analysis.size(), table_.size());
    for (size_t s = 0; s < n; ++s) {
        if (!table_[s].resident()) continue;
        Node& node = nodes_[s];
        node.edges = analysis[s].edges;
        node.benefit = analysis[s].benefit;
        if (analysis[s].used == 0) continue;
        // A lookup that ended here walked through every ancestor.
        for (int32_t a = int32_t(s); a != kNoNode && nodes_[uint32_t(a)].lastUsed != frame; a = nodes_[uint32_t(a)].parent)
            nodes_[uint32_t(a)].lastUsed = frame;
    }
}

int32_t TileTree::leastRecentlyUsedLeaf(uint64_t before) const
{
    int32_t best = kNoNode;
    for (uint32_t s = 0; s < slots(); ++s) {
        const GpuNode& n = table_[s];
        if (!n.resident() || n.level <= baseLevel_ || nodes_[s].lastUsed >= before || !isLeaf(s)) continue;
        if (best == kNoNode) {
            best = int32_t(s);
            continue;
        }
        const Node& b = nodes_[uint32_t(best)];
        // Least recently used first; among equals the deepest (the finest detail goes first).
        if (nodes_[s].lastUsed < b.lastUsed || (nodes_[s].lastUsed == b.lastUsed && n.level > table_[uint32_t(best)].level))
            best = int32_t(s);
    }
    return best;
}

int32_t TileTree::weakestLeaf(int32_t keep) const
{
    int32_t best = kNoNode;
    for (uint32_t s = 0; s < slots(); ++s) {
        const GpuNode& n = table_[s];
        if (!n.resident() || n.level <= baseLevel_ || int32_t(s) == keep || !isLeaf(s)) continue;
        if (best == kNoNode || nodes_[s].edges < nodes_[uint32_t(best)].edges) best = int32_t(s);
    }
    return best;
}

RefineStep TileTree::refine(const RefineBudget& budget)
{
    struct Candidate {
        uint32_t parent;
        uint32_t quadrant;
        uint32_t benefit;
        uint32_t level;
    };
    std::vector<Candidate> candidates;
    for (uint32_t s = 0; s < slots(); ++s) {
        const GpuNode& n = table_[s];
        if (!n.resident() || n.level >= maxLevel_) continue;
        for (uint32_t q = 0; q < 4; ++q)
            if (n.children[q] == kNoNode && nodes_[s].benefit[q] >= std::max(budget.minBenefit, 1u))
                candidates.push_back({s, q, nodes_[s].benefit[q], n.level});
    }
    // Every tile costs the same (a N + b with N = tile²), so benefit per cost orders as the
    // benefit does; coarser cells first among equals (their children serve more of the
    // view next time), then by slot for a deterministic order.
    std::ranges::sort(candidates, [](const Candidate& a, const Candidate& b) {
        if (a.benefit != b.benefit) return a.benefit > b.benefit;
        if (a.level != b.level) return a.level < b.level;
        return a.parent != b.parent ? a.parent < b.parent : a.quadrant < b.quadrant;
    });
    RefineStep step;
    step.candidates = uint32_t(candidates.size());
    const double fit = budget.tileCostMs > 0.0 ? std::floor(budget.budgetMs / budget.tileCostMs) : double(slots());
    const size_t allowed = std::max<size_t>(1, size_t(std::clamp(fit, 0.0, double(slots()))));
    // The candidates' parents as they were: a parent removed (and its slot reused) during
    // this step no longer asks for anything.
    std::vector<GpuNode> parents;
    parents.reserve(candidates.size());
    for (const Candidate& c : candidates) parents.push_back(table_[c.parent]);
    for (size_t i = 0; i < candidates.size(); ++i) {
        const Candidate& c = candidates[i];
        if (step.created.size() >= allowed) {
            step.deferred += uint32_t(candidates.size() - i);
            break;
        }
        const GpuNode& p = table_[c.parent];
        if (!p.resident() || p.face != parents[i].face || p.level != parents[i].level || p.x != parents[i].x || p.y != parents[i].y ||
            p.children[c.quadrant] != kNoNode)
            continue;
        int32_t slot = kNoNode;
        if (!free_.empty()) {
            slot = int32_t(free_.back());
            free_.pop_back();
        } else if (const int32_t lru = leastRecentlyUsedLeaf(lastAnalyzed_); lru != kNoNode) {
            remove(uint32_t(lru));
            ++step.evicted;
            slot = int32_t(free_.back());
            free_.pop_back();
        } else {
            // Everything is in use: replace only for a greater benefit. Later candidates
            // have less, and the weakest leaf stays the weakest: the step ends here.
            const int32_t weakest = weakestLeaf(int32_t(c.parent));
            if (weakest == kNoNode || nodes_[uint32_t(weakest)].edges >= c.benefit) {
                step.deferred += uint32_t(candidates.size() - i);
                break;
            }
            remove(uint32_t(weakest));
            ++step.evicted;
            slot = int32_t(free_.back());
            free_.pop_back();
        }
        step.created.push_back(create(int32_t(c.parent), c.quadrant, uint32_t(slot)));
    }
    return step;
}

bool TileTree::wantsMore(uint32_t minBenefit) const
{
    uint32_t best = 0;
    for (uint32_t s = 0; s < slots(); ++s) {
        const GpuNode& n = table_[s];
        if (!n.resident() || n.level >= maxLevel_) continue;
        for (uint32_t q = 0; q < 4; ++q)
            if (n.children[q] == kNoNode && nodes_[s].benefit[q] >= std::max(minBenefit, 1u))
                best = std::max(best, nodes_[s].benefit[q]);
    }
    if (best == 0) return false;
    if (!free_.empty() || leastRecentlyUsedLeaf(lastAnalyzed_) != kNoNode) return true;
    const int32_t weakest = weakestLeaf(kNoNode);
    return weakest != kNoNode && nodes_[uint32_t(weakest)].edges < best;
}

uint32_t TileTree::invalidate(uint32_t face, float loU, float loV, float hiU, float hiV)
{
    uint32_t count = 0;
    for (uint32_t s = 0; s < slots(); ++s) {
        const GpuNode& n = table_[s];
        if (n.face != face) continue;
        const float size = std::ldexp(1.0f, -int(n.level));
        const float u0 = float(n.x) * size, v0 = float(n.y) * size;
        if (u0 > hiU || u0 + size < loU || v0 > hiV || v0 + size < loV) continue;
        if (std::ranges::find(pending_, s) == pending_.end()) pending_.push_back(s);
        ++count;
    }
    return count;
}

std::vector<uint32_t> TileTree::takePending()
{
    std::vector<uint32_t> pending;
    pending.swap(pending_);
    return pending;
}

void TileTree::bottomUpOrder(std::vector<uint32_t>& order, std::array<uint32_t, kMaxLevels + 1>& levelStart) const
{
    order.clear();
    levelStart.fill(0);
    for (uint32_t i = 0; i < kMaxLevels; ++i) {
        const uint32_t level = maxLevel_ >= i ? maxLevel_ - i : kMaxLevels;
        levelStart[i] = uint32_t(order.size());
        if (level == kMaxLevels) continue;
        for (uint32_t s = 0; s < slots(); ++s)
            if (table_[s].resident() && table_[s].level == level) order.push_back(s);
    }
    levelStart[kMaxLevels] = uint32_t(order.size());
}

void TileTree::pageTable(uint32_t level, std::vector<int32_t>& pages) const
{
    const uint32_t side = 1u << level;
    pages.resize(size_t(faces_) * side * side);
    for (uint32_t f = 0; f < faces_; ++f)
        for (uint32_t cy = 0; cy < side; ++cy)
            for (uint32_t cx = 0; cx < side; ++cx) {
                uint32_t node = f;
                for (uint32_t l = 0; l < level; ++l) {
                    const uint32_t shift = level - 1 - l;
                    const int32_t child = table_[node].children[((cx >> shift) & 1u) + 2 * ((cy >> shift) & 1u)];
                    if (child == kNoNode) break;
                    node = uint32_t(child);
                }
                pages[(size_t(f) * side + cy) * side + cx] = int32_t(node);
            }
}

uint32_t TileTree::deepestLevel() const
{
    uint32_t deepest = 0;
    for (const GpuNode& n : table_)
        if (n.resident()) deepest = std::max(deepest, n.level);
    return deepest;
}

} // namespace penumbra::adaptive_sm
