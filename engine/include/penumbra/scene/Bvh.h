#pragma once
// A bounding volume hierarchy over instance world boxes: view-frustum culling, box
// overlap, picking rays, and a nearest-first node traversal for occlusion culling
// (CHC++, Mattausch et al. 2008). Built with binned SAH (Wald 2007), refitted bottom-up
// when instances move, rebuilt when refitting has worn the tree out.
//
// Boxes that cannot be placed — a NaN or infinite coordinate, or min > max on an axis
// (Aabb{} is such a box) — keep their instance index but count as empty: no query ever
// returns them, and a later refit with a real box brings them back.
//
// Queries are const and keep their state on the stack, so several threads may query one
// tree at once; building and refitting need exclusive access.
#include "penumbra/scene/Scene.h"

#include <glm/glm.hpp>

#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <span>
#include <vector>

namespace penumbra::scene {

// A convex volume bounded by planes; a point p is inside plane i when
// dot(planes[i].xyz, p) + planes[i].w >= 0. The normals are unit length and point inward.
struct Frustum {
    std::array<glm::vec4, 6> planes{};
    uint32_t planeCount = 0;
};

// The frustum of a Vulkan view-projection matrix (clip x, y in [-w, w], depth z/w in
// [0, 1]) with the engine's reversed-Z (render/Projection.h): planes left, right, top,
// bottom, near (depth <= 1), far (depth >= 0), extracted from the matrix rows (Gribb &
// Hartmann 2001). With the engine's infinite far plane, clip z is the constant `near`, so
// the far-plane row has a zero normal: it bounds nothing and is left out (planeCount 5).
// A finite reversed-Z projection keeps its far plane (planeCount 6). Throws Error if the
// matrix holds a NaN or an infinity.
Frustum frustumFromViewProj(const glm::mat4& viewProj);

// Points origin + t * direction for t in [tMin, tMax]. The direction need not be unit
// length; t is measured in multiples of it.
struct Ray {
    glm::vec3 origin{0.0f};
    glm::vec3 direction{0.0f, 0.0f, -1.0f};
    float tMin = 0.0f;
    float tMax = std::numeric_limits<float>::infinity();
};

struct RayHit {
    uint32_t instance;
    float t;  // box-only queries: where the ray enters the box (tMin when it starts inside)
};

// Tests one instance's own geometry (its triangles, say) against `ray`, whose tMax is the
// closest hit found so far; returns the hit's t, or nothing. A t outside
// [ray.tMin, ray.tMax] is ignored.
using InstanceRayTest = std::function<std::optional<float>(uint32_t instance, const Ray& ray)>;

// One node as traverseFrontToBack shows it.
struct BvhNodeVisit {
    uint32_t node;    // 0 is the root; indices hold across refits, not across rebuilds
    uint32_t parent;  // InstanceBvh::kNoNode for the root
    const Aabb& bounds;
    float distanceSq;                     // squared distance from the point to `bounds`, 0 inside
    std::span<const uint32_t> instances;  // a leaf's instances; empty for an inner node
};

// Returns false to skip the node's subtree.
using BvhNodeVisitor = std::function<bool(const BvhNodeVisit& visit)>;

enum class RefitAction { Refitted, Rebuilt };

struct RefitReport {
    RefitAction action;
    double refitSahCost;  // after the refit; infinity when the instance count changed
    double builtSahCost;  // right after the build it was compared against
};

class InstanceBvh {
public:
    static constexpr uint32_t kNoNode = std::numeric_limits<uint32_t>::max();
    static constexpr uint32_t kMaxLeafInstances = 4;
    static constexpr uint32_t kMaxInstances = 1u << 31;
    // refitOrRebuild's default threshold, the ratio of refitted to built SAH cost; see
    // Bvh.cpp for why 1.5.
    static constexpr double kRebuildCostRatio = 1.5;

    InstanceBvh() = default;  // no instances
    // Instance i has the box bounds[i]. Throws Error for more than kMaxInstances boxes.
    explicit InstanceBvh(std::span<const Aabb> bounds);

    // New boxes for the same instances, same tree: O(nodes). Throws Error if the count
    // differs from the build's (adding or removing instances needs a new tree).
    void refit(std::span<const Aabb> bounds);
    // Takes new boxes for the `changed` instances only (as Scene::updateTransforms returns
    // them) and updates their ancestors: O(changed · depth). Throws Error as refit does,
    // or for an index out of range.
    void refit(std::span<const Aabb> bounds, std::span<const uint32_t> changed);
    // Refits, then rebuilds if the SAH cost grew past maxCostRatio times the cost of the
    // last build, or if the instance count changed.
    RefitReport refitOrRebuild(std::span<const Aabb> bounds, double maxCostRatio = kRebuildCostRatio);
    RefitReport refitOrRebuild(std::span<const Aabb> bounds, std::span<const uint32_t> changed,
                               double maxCostRatio = kRebuildCostRatio);

    // Each query replaces the contents of its output vector.

    // Instances whose box lies inside the frustum or cuts it. A box is dropped only when
    // it lies entirely on the outer side of one plane, so everything that touches the
    // frustum is kept, and some boxes near its edges that miss it are kept too. Throws
    // Error for a planeCount above 6.
    void cullFrustum(const Frustum& frustum, std::vector<uint32_t>& visible) const;
    // Instances whose box overlaps `box` (touching counts). A box that cannot be placed
    // overlaps nothing.
    void findOverlapping(const Aabb& box, std::vector<uint32_t>& found) const;

    // The instance whose box the ray enters first (ties: the lower index). A ray with a NaN
    // anywhere, or an infinite origin or direction, hits nothing. A ray that runs exactly
    // along a box face hits the box.
    std::optional<RayHit> closestHit(const Ray& ray) const;
    // The closest hit that `test` reports, asking it only about instances whose box the
    // ray enters before the closest hit so far, nearest nodes first. Throws Error if
    // `test` is empty.
    std::optional<RayHit> closestHit(const Ray& ray, const InstanceRayTest& test) const;
    // Every box the ray enters, sorted by entry t (ties: by index).
    void findAllHits(const Ray& ray, std::vector<RayHit>& hits) const;

    // Visits nodes in non-decreasing distance from `point` to their box (ties: by node
    // index), so every node comes after its parent. Nodes with no placeable box are not
    // visited; a leaf lists all its instances, placeable or not. A point with a NaN or
    // infinite coordinate visits nothing. Throws Error if `visit` is empty.
    void traverseFrontToBack(const glm::vec3& point, const BvhNodeVisitor& visit) const;

    size_t instanceCount() const { return order_.size(); }
    size_t nodeCount() const { return nodes_.size(); }

    // The nodes themselves, for traversals that keep per-node state across frames
    // (hierarchical occlusion culling). `node` < nodeCount(); parents come before their
    // children, so a loop from the last node to the first sees every child before its
    // parent.
    const Aabb& nodeBounds(uint32_t node) const { return nodes_.at(node).bounds; }
    bool isLeafNode(uint32_t node) const { return isLeaf(nodes_.at(node)); }
    // An inner node's two children (the second is the first + 1); a leaf has none.
    uint32_t firstChild(uint32_t node) const { return nodes_.at(node).first; }
    uint32_t parentNode(uint32_t node) const { return parents_.at(node); }
    // A leaf's instances; empty for an inner node.
    std::span<const uint32_t> leafInstances(uint32_t node) const
    {
        const Node& n = nodes_.at(node);
        return isLeaf(n) ? std::span<const uint32_t>(order_).subspan(n.first, n.count) : std::span<const uint32_t>();
    }
    // Expected box tests per random ray, the surface area heuristic (MacDonald & Booth
    // 1990): the sum over nodes of area(node) / area(root), weighted by the instance count
    // for a leaf. 0 for an empty tree or one whose root box has no area.
    double sahCost() const;
    double builtSahCost() const { return builtSahCost_; }

private:
    struct Node {
        Aabb bounds;     // of the placeable boxes below
        uint32_t first;  // leaf: first slot in order_; inner node: first child, the second is first + 1
        uint32_t count;  // instances below; a node with at most kMaxLeafInstances is a leaf
    };

    void build(std::span<const Aabb> bounds);
    uint32_t splitRange(uint32_t first, uint32_t count, const std::vector<glm::vec3>& centroids,
                        const std::vector<Aabb>& boxes, uint32_t depth);
    void refitNode(uint32_t node);
    void appendSubtree(uint32_t node, std::vector<uint32_t>& out) const;
    template <class TestInstance>
    std::optional<RayHit> closestHitWith(const Ray& ray, TestInstance&& test) const;
    RefitReport rebuildIfWorn(std::span<const Aabb> bounds, double maxCostRatio);
    static bool isLeaf(const Node& node) { return node.count <= kMaxLeafInstances; }

    std::vector<Node> nodes_;        // parents before children; root at 0
    std::vector<uint32_t> parents_;  // per node
    std::vector<uint32_t> order_;    // slot -> instance; each leaf owns a run of slots
    std::vector<Aabb> slotBoxes_;    // slot -> box (empty when it cannot be placed)
    std::vector<uint32_t> slotOf_;   // instance -> slot
    std::vector<uint32_t> leafOf_;   // instance -> leaf node
    std::vector<uint8_t> nodeDirty_;         // refit of a subset: scratch, all 0 between calls
    std::vector<uint32_t> dirtyNodes_;       // refit of a subset: scratch
    double builtSahCost_ = 0.0;
};

// The instances' world boxes, in instance order: what an InstanceBvh over a scene is built
// and refitted from.
std::vector<Aabb> instanceWorldBounds(std::span<const Instance> instances);

} // namespace penumbra::scene
