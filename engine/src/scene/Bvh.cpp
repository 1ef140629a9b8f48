#include "penumbra/scene/Bvh.h"

#include "penumbra/core/Error.h"
#include "core/Finite.h"

#include <fmt/format.h>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <numeric>

namespace penumbra::scene {

namespace {

// Centroid bins per split (Wald 2007 finds 16 within a few per cent of a full sweep).
constexpr uint32_t kBins = 16;

// Splits follow the SAH down to this depth and halve their run of instances below it, so
// no leaf lies deeper than kMaxSahDepth + 30 (2^32 instances halved 30 times leave 4)
// whatever the input, even where the SAH peels one box at a time off a degenerate set.
// That bound sizes the fixed traversal stacks: a depth-first walk holds at most one
// pending sibling per level.
constexpr uint32_t kMaxSahDepth = 64;
constexpr size_t kStackCapacity = 128;
static_assert(kMaxSahDepth + 30 + 1 <= kStackCapacity);

// planesCutting's answer for a box entirely outside one plane (a real mask has 6 bits).
constexpr uint32_t kOutside = std::numeric_limits<uint32_t>::max();

using core::isFinite;

// `!(min <= max)` also catches NaN, which fails every comparison.
bool isPlaceable(const Aabb& box)
{
    return isFinite(box.min) && isFinite(box.max) && box.min.x <= box.max.x && box.min.y <= box.max.y &&
           box.min.z <= box.max.z;
}

Aabb placed(const Aabb& box) { return isPlaceable(box) ? box : Aabb{}; }

// Aabb::extend, inlined: the build and refit grow boxes millions of times, and the call
// into Scene.cpp took half the build time. No branch for empty boxes: every box here is
// placeable or exactly Aabb{}, whose min and max leave any box as it is.
void enclose(Aabb& box, const Aabb& other)
{
    box.min = glm::min(box.min, other.min);
    box.max = glm::max(box.max, other.max);
}

void enclose(Aabb& box, const glm::vec3& point)
{
    box.min = glm::min(box.min, point);
    box.max = glm::max(box.max, point);
}

// Not Aabb::center(): min + max overflows for boxes near the ends of the float range.
glm::vec3 centroid(const Aabb& box) { return 0.5f * box.min + 0.5f * box.max; }

// In double: float extents near the top of the float range overflow when multiplied.
double halfArea(const Aabb& box)
{
    if (box.empty()) return 0.0;
    const glm::dvec3 e = glm::dvec3(box.max) - glm::dvec3(box.min);
    return e.x * e.y + e.y * e.z + e.z * e.x;
}

bool overlaps(const Aabb& a, const Aabb& b)
{
    return a.min.x <= b.max.x && b.min.x <= a.max.x && a.min.y <= b.max.y && b.min.y <= a.max.y &&
           a.min.z <= b.max.z && b.min.z <= a.max.z;
}

float signedDistance(const glm::vec4& plane, const glm::vec3& p)
{
    return plane.x * p.x + plane.y * p.y + plane.z * p.z + plane.w;
}

// The planes of `planeMask` that still cut `box`, without those it lies fully inside, or
// kOutside when it lies fully outside one of them. The corner farthest along a plane's
// normal (the p-vertex) decides "outside", the nearest (the n-vertex) "fully inside"
// (Assarsson & Möller 2000, with their plane masking). What holds for a box holds for
// every box within it, so a node hands its mask down to its children; and both tests are
// monotone in the corners under float rounding too, so a node is never culled while a box
// inside it would pass.
uint32_t planesCutting(const Aabb& box, const Frustum& frustum, uint32_t planeMask)
{
    uint32_t cutting = planeMask;
    for (uint32_t i = 0; i < frustum.planeCount; ++i) {
        const uint32_t bit = 1u << i;
        if (!(planeMask & bit)) continue;
        const glm::vec4& plane = frustum.planes[i];
        const glm::vec3 pVertex{plane.x >= 0.0f ? box.max.x : box.min.x, plane.y >= 0.0f ? box.max.y : box.min.y,
                                plane.z >= 0.0f ? box.max.z : box.min.z};
        if (signedDistance(plane, pVertex) < 0.0f) return kOutside;
        const glm::vec3 nVertex{plane.x >= 0.0f ? box.min.x : box.max.x, plane.y >= 0.0f ? box.min.y : box.max.y,
                                plane.z >= 0.0f ? box.min.z : box.max.z};
        if (signedDistance(plane, nVertex) >= 0.0f) cutting &= ~bit;
    }
    return cutting;
}

bool isUsable(const Ray& ray)
{
    return isFinite(ray.origin) && isFinite(ray.direction) && !std::isnan(ray.tMin) && !std::isnan(ray.tMax);
}

// A ray set up for slab tests (Kay & Kajiya 1986): reciprocal direction and, per axis,
// which box side it meets first.
struct RaySlabs {
    explicit RaySlabs(const Ray& ray)
        : origin(ray.origin), inverseDirection(1.0f / ray.direction),
          negative{std::signbit(ray.direction.x), std::signbit(ray.direction.y), std::signbit(ray.direction.z)}
    {
    }
    glm::vec3 origin;
    glm::vec3 inverseDirection;  // ±inf on an axis the ray runs parallel to
    std::array<bool, 3> negative;
};

// Whether the ray meets `box` within [tMin, tMax], and where it enters. Choosing the near
// side by the direction's sign (Williams et al. 2005), rather than taking the smaller of
// the two slab distances, makes an empty box (min > max) miss. On an axis the ray runs
// parallel to, a slab distance is ±inf (a miss or no limit), or NaN, 0 * inf, when the
// ray lies in the plane of a face: NaN fails both comparisons and sets no limit, so a ray
// along a face hits the box, as touching counts everywhere else.
bool enterBox(const Aabb& box, const RaySlabs& ray, float tMin, float tMax, float& tEntry)
{
    for (int axis = 0; axis < 3; ++axis) {
        const bool negative = ray.negative[axis];
        const float tNear = ((negative ? box.max[axis] : box.min[axis]) - ray.origin[axis]) * ray.inverseDirection[axis];
        const float tFar = ((negative ? box.min[axis] : box.max[axis]) - ray.origin[axis]) * ray.inverseDirection[axis];
        if (tNear > tMin) tMin = tNear;
        if (tFar < tMax) tMax = tFar;
    }
    tEntry = tMin;
    return tMin <= tMax;
}

// The lower instance index wins ties, so results do not depend on traversal order.
bool isCloser(float t, uint32_t instance, const RayHit& best)
{
    return t < best.t || (t == best.t && instance < best.instance);
}

float distanceSq(const glm::vec3& point, const Aabb& box)
{
    const glm::vec3 outside = glm::max(glm::max(box.min - point, point - box.max), glm::vec3(0.0f));
    return glm::dot(outside, outside);
}

} // namespace

Frustum frustumFromViewProj(const glm::mat4& viewProj)
{
    for (int column = 0; column < 4; ++column) {
        for (int row = 0; row < 4; ++row) {
            if (!std::isfinite(viewProj[column][row])) {
                throw Error(fmt::format("frustumFromViewProj: viewProj[{}][{}] (column, row) is {}; the "
                                        "view-projection matrix must be finite",
                                        column, row, viewProj[column][row]));
            }
        }
    }
    // In double: each plane is the sum or difference of two rows, which may nearly cancel.
    const glm::dmat4 m(viewProj);
    const auto row = [&](int r) { return glm::dvec4(m[0][r], m[1][r], m[2][r], m[3][r]); };
    // x >= -w, x <= w, y >= -w, y <= w, z <= w (depth <= 1: near), z >= 0 (depth >= 0: far).
    const std::array<glm::dvec4, 6> rows{row(3) + row(0), row(3) - row(0), row(3) + row(1),
                                         row(3) - row(1), row(3) - row(2), row(2)};
    Frustum frustum;
    for (const glm::dvec4& plane : rows) {
        const double normalLength = glm::length(glm::dvec3(plane));
        // A zero normal (0/0 or d/0 below) is a plane at infinity: the far plane of an
        // infinite projection, whose clip z is the constant `near`. A plane farther from
        // the origin than the float range reaches bounds no float box either.
        if (!(std::abs(plane.w) / normalLength <= double(FLT_MAX))) continue;
        frustum.planes[frustum.planeCount++] = glm::vec4(plane / normalLength);
    }
    return frustum;
}

InstanceBvh::InstanceBvh(std::span<const Aabb> bounds) { build(bounds); }

void InstanceBvh::build(std::span<const Aabb> bounds)
{
    // 2n - 1 nodes must stay below kNoNode.
    if (bounds.size() > kMaxInstances) {
        throw Error(fmt::format("InstanceBvh: {} instance boxes; 32-bit node indices allow at most {}", bounds.size(),
                                kMaxInstances));
    }
    const auto n = static_cast<uint32_t>(bounds.size());
    std::vector<Aabb> boxes(n);
    std::vector<glm::vec3> centroids(n, glm::vec3(0.0f));
    for (uint32_t i = 0; i < n; ++i) {
        boxes[i] = placed(bounds[i]);
        if (!boxes[i].empty()) centroids[i] = centroid(boxes[i]);
    }
    order_.resize(n);
    std::iota(order_.begin(), order_.end(), 0u);
    // Placeable boxes first: the root's split puts the others in a subtree of their own,
    // where their made-up centroids cannot stretch the bins of real boxes.
    const auto placeableCount = static_cast<uint32_t>(
        std::partition(order_.begin(), order_.end(), [&](uint32_t i) { return !boxes[i].empty(); }) - order_.begin());

    nodes_.clear();
    parents_.clear();
    if (n > 0) {
        nodes_.reserve(2 * size_t(n) - 1);
        parents_.reserve(2 * size_t(n) - 1);
        nodes_.push_back({Aabb{}, 0, n});
        parents_.push_back(kNoNode);
    }
    struct Task {
        uint32_t node;
        uint32_t depth;
    };
    std::vector<Task> tasks;
    if (n > 0) tasks.push_back({0, 0});
    while (!tasks.empty()) {
        const Task task = tasks.back();
        tasks.pop_back();
        const uint32_t first = nodes_[task.node].first;
        const uint32_t count = nodes_[task.node].count;
        if (count <= kMaxLeafInstances) continue;
        const bool splitOffUnplaceable = task.node == 0 && placeableCount > 0 && placeableCount < n;
        const uint32_t leftCount =
            splitOffUnplaceable ? placeableCount : splitRange(first, count, centroids, boxes, task.depth);
        const auto left = static_cast<uint32_t>(nodes_.size());
        nodes_.push_back({Aabb{}, first, leftCount});
        nodes_.push_back({Aabb{}, first + leftCount, count - leftCount});
        parents_.insert(parents_.end(), 2, task.node);
        nodes_[task.node].first = left;
        tasks.push_back({left + 1, task.depth + 1});
        tasks.push_back({left, task.depth + 1});
    }

    slotBoxes_.resize(n);
    slotOf_.resize(n);
    leafOf_.resize(n);
    for (uint32_t slot = 0; slot < n; ++slot) {
        slotBoxes_[slot] = boxes[order_[slot]];
        slotOf_[order_[slot]] = slot;
    }
    for (uint32_t node = 0; node < nodes_.size(); ++node) {
        if (!isLeaf(nodes_[node])) continue;
        for (uint32_t slot = nodes_[node].first; slot < nodes_[node].first + nodes_[node].count; ++slot) {
            leafOf_[order_[slot]] = node;
        }
    }
    nodeDirty_.assign(nodes_.size(), 0);
    dirtyNodes_.clear();
    for (auto node = static_cast<uint32_t>(nodes_.size()); node-- > 0;) refitNode(node);
    builtSahCost_ = sahCost();
}

// Splits order_[first, first + count) into two non-empty runs; returns the first's length.
uint32_t InstanceBvh::splitRange(uint32_t first, uint32_t count, const std::vector<glm::vec3>& centroids,
                                 const std::vector<Aabb>& boxes, uint32_t depth)
{
    const auto begin = order_.begin() + first;
    const auto end = begin + count;
    Aabb nodeBox;
    Aabb centroidBox;
    for (auto it = begin; it != end; ++it) {
        enclose(nodeBox, boxes[*it]);
        enclose(centroidBox, centroids[*it]);
    }
    const glm::vec3 spread = centroidBox.max - centroidBox.min;  // inf where the difference overflows
    const int axis = spread.x >= spread.y && spread.x >= spread.z ? 0 : (spread.y >= spread.z ? 1 : 2);
    const float binsPerUnit = float(kBins) / spread[axis];

    // The SAH needs areas to compare and distinct centroids to bin. Without them (equal
    // centroids; points or segments on a line, whose boxes have no area) or below the
    // depth cap, split at the median, which at least halves the run.
    if (depth >= kMaxSahDepth || halfArea(nodeBox) == 0.0 || !(spread[axis] > 0.0f) || !std::isfinite(spread[axis]) ||
        !std::isfinite(binsPerUnit)) {
        std::nth_element(begin, begin + count / 2, end,
                         [&](uint32_t a, uint32_t b) { return centroids[a][axis] < centroids[b][axis]; });
        return count / 2;
    }

    // The lowest centroid falls in bin 0 and the highest in the last bin (the product
    // below comes within a few ulps of kBins), so every split between bins leaves both
    // sides non-empty.
    const float low = centroidBox.min[axis];
    const auto binOf = [&](uint32_t instance) {
        return std::min(kBins - 1, static_cast<uint32_t>((centroids[instance][axis] - low) * binsPerUnit));
    };
    struct Bin {
        Aabb box;
        uint32_t count = 0;
    };
    std::array<Bin, kBins> bins{};
    for (auto it = begin; it != end; ++it) {
        Bin& bin = bins[binOf(*it)];
        ++bin.count;
        enclose(bin.box, boxes[*it]);
    }
    // SAH cost of splitting after bin b: area(left) * count(left) + area(right) * count(right)
    // (the node's own area and the traversal cost are the same for every b).
    std::array<double, kBins - 1> rightCost{};
    Aabb right;
    uint32_t rightCount = 0;
    for (uint32_t b = kBins - 1; b > 0; --b) {
        enclose(right, bins[b].box);
        rightCount += bins[b].count;
        rightCost[b - 1] = halfArea(right) * rightCount;
    }
    Aabb left;
    uint32_t leftCount = 0;
    uint32_t bestSplit = 0;
    double bestCost = std::numeric_limits<double>::infinity();
    for (uint32_t b = 0; b + 1 < kBins; ++b) {
        enclose(left, bins[b].box);
        leftCount += bins[b].count;
        const double cost = halfArea(left) * leftCount + rightCost[b];
        if (cost < bestCost) {
            bestCost = cost;
            bestSplit = b;
        }
    }
    return static_cast<uint32_t>(std::partition(begin, end, [&](uint32_t i) { return binOf(i) <= bestSplit; }) - begin);
}

void InstanceBvh::refitNode(uint32_t index)
{
    Node& node = nodes_[index];
    Aabb box;
    if (isLeaf(node)) {
        for (uint32_t slot = node.first; slot < node.first + node.count; ++slot) enclose(box, slotBoxes_[slot]);
    } else {
        enclose(box, nodes_[node.first].bounds);
        enclose(box, nodes_[node.first + 1].bounds);
    }
    node.bounds = box;
}

void InstanceBvh::refit(std::span<const Aabb> bounds)
{
    if (bounds.size() != order_.size()) {
        throw Error(fmt::format("InstanceBvh::refit: {} boxes for a tree over {} instances; build a new tree when "
                                "instances are added or removed",
                                bounds.size(), order_.size()));
    }
    for (uint32_t instance = 0; instance < order_.size(); ++instance) slotBoxes_[slotOf_[instance]] = placed(bounds[instance]);
    // Children have larger indices than their parents.
    for (auto node = static_cast<uint32_t>(nodes_.size()); node-- > 0;) refitNode(node);
}

void InstanceBvh::refit(std::span<const Aabb> bounds, std::span<const uint32_t> changed)
{
    if (bounds.size() != order_.size()) {
        throw Error(fmt::format("InstanceBvh::refit: {} boxes for a tree over {} instances; build a new tree when "
                                "instances are added or removed",
                                bounds.size(), order_.size()));
    }
    // All checks before any change, so that a throw leaves the tree and the scratch as they were.
    for (uint32_t instance : changed) {
        if (instance >= order_.size()) {
            throw Error(fmt::format("InstanceBvh::refit: changed instance {} does not exist (the tree has {})",
                                    instance, order_.size()));
        }
    }
    for (uint32_t instance : changed) {
        slotBoxes_[slotOf_[instance]] = placed(bounds[instance]);
        for (uint32_t node = leafOf_[instance]; node != kNoNode && !nodeDirty_[node]; node = parents_[node]) {
            nodeDirty_[node] = 1;
            dirtyNodes_.push_back(node);
        }
    }
    // Children have larger indices than their parents: decreasing order finishes every
    // child before its parent.
    std::sort(dirtyNodes_.begin(), dirtyNodes_.end(), std::greater<>());
    for (uint32_t node : dirtyNodes_) {
        refitNode(node);
        nodeDirty_[node] = 0;
    }
    dirtyNodes_.clear();
}

// 1.5 by default (kRebuildCostRatio). The SAH cost is the expected number of box tests per
// ray, and query time follows it, so at 1.5 queries run at most about half again as long
// as on a fresh tree. Animation jitter moves the cost by a few per cent (1.01 after
// bench_bvh's BvhRefit) and never gets there; instances that trade places push it to many
// times the built cost within a few frames. A rebuild costs about 30 full refits
// (bench_bvh), a price paid once, whereas a worn tree slows every query of every frame.
RefitReport InstanceBvh::rebuildIfWorn(std::span<const Aabb> bounds, double maxCostRatio)
{
    const double refitCost = sahCost();
    const RefitReport report{refitCost > maxCostRatio * builtSahCost_ ? RefitAction::Rebuilt : RefitAction::Refitted,
                             refitCost, builtSahCost_};
    if (report.action == RefitAction::Rebuilt) build(bounds);
    return report;
}

RefitReport InstanceBvh::refitOrRebuild(std::span<const Aabb> bounds, double maxCostRatio)
{
    if (bounds.size() != order_.size()) {
        const double builtCost = builtSahCost_;
        build(bounds);
        return {RefitAction::Rebuilt, std::numeric_limits<double>::infinity(), builtCost};
    }
    refit(bounds);
    return rebuildIfWorn(bounds, maxCostRatio);
}

RefitReport InstanceBvh::refitOrRebuild(std::span<const Aabb> bounds, std::span<const uint32_t> changed,
                                        double maxCostRatio)
{
    if (bounds.size() != order_.size()) return refitOrRebuild(bounds, maxCostRatio);
    refit(bounds, changed);
    return rebuildIfWorn(bounds, maxCostRatio);
}

double InstanceBvh::sahCost() const
{
    if (nodes_.empty()) return 0.0;
    const double rootArea = halfArea(nodes_[0].bounds);
    if (rootArea == 0.0) return 0.0;
    double weightedArea = 0.0;
    for (const Node& node : nodes_) weightedArea += halfArea(node.bounds) * (isLeaf(node) ? node.count : 1u);
    return weightedArea / rootArea;
}

// A subtree's instances fill one run of slots (the build partitions runs in place), which
// starts at its leftmost leaf.
void InstanceBvh::appendSubtree(uint32_t index, std::vector<uint32_t>& out) const
{
    uint32_t leftmost = index;
    while (!isLeaf(nodes_[leftmost])) leftmost = nodes_[leftmost].first;
    const uint32_t first = nodes_[leftmost].first;
    for (uint32_t slot = first; slot < first + nodes_[index].count; ++slot) {
        if (!slotBoxes_[slot].empty()) out.push_back(order_[slot]);
    }
}

void InstanceBvh::cullFrustum(const Frustum& frustum, std::vector<uint32_t>& visible) const
{
    visible.clear();
    if (frustum.planeCount > frustum.planes.size()) {
        throw Error(fmt::format("InstanceBvh::cullFrustum: planeCount is {}; a frustum has at most {} planes",
                                frustum.planeCount, frustum.planes.size()));
    }
    if (nodes_.empty()) return;
    struct Entry {
        uint32_t node;
        uint32_t planeMask;  // the planes that cut its parent
    };
    std::array<Entry, kStackCapacity> stack;
    size_t size = 0;
    stack[size++] = {0, (1u << frustum.planeCount) - 1};
    while (size > 0) {
        const Entry entry = stack[--size];
        const Node& node = nodes_[entry.node];
        if (node.bounds.empty()) continue;
        const uint32_t cutting = planesCutting(node.bounds, frustum, entry.planeMask);
        if (cutting == kOutside) continue;
        if (cutting == 0) {
            appendSubtree(entry.node, visible);
        } else if (isLeaf(node)) {
            for (uint32_t slot = node.first; slot < node.first + node.count; ++slot) {
                const Aabb& box = slotBoxes_[slot];
                if (!box.empty() && planesCutting(box, frustum, cutting) != kOutside) visible.push_back(order_[slot]);
            }
        } else {
            stack[size++] = {node.first + 1, cutting};
            stack[size++] = {node.first, cutting};
        }
    }
}

void InstanceBvh::findOverlapping(const Aabb& box, std::vector<uint32_t>& found) const
{
    found.clear();
    if (nodes_.empty() || !isPlaceable(box)) return;
    std::array<uint32_t, kStackCapacity> stack;
    size_t size = 0;
    stack[size++] = 0;
    while (size > 0) {
        const Node& node = nodes_[stack[--size]];
        // An empty box (min > max) overlaps nothing: its min exceeds every max.
        if (!overlaps(node.bounds, box)) continue;
        if (isLeaf(node)) {
            for (uint32_t slot = node.first; slot < node.first + node.count; ++slot) {
                if (overlaps(slotBoxes_[slot], box)) found.push_back(order_[slot]);
            }
        } else {
            stack[size++] = node.first + 1;
            stack[size++] = node.first;
        }
    }
}

// `test(instance, tEntry, tMax)` returns the t of a hit on the instance, or nothing.
template <class TestInstance>
std::optional<RayHit> InstanceBvh::closestHitWith(const Ray& ray, TestInstance&& test) const
{
    if (nodes_.empty() || !isUsable(ray)) return std::nullopt;
    const RaySlabs slabs(ray);
    RayHit best{kNoNode, ray.tMax};
    struct Entry {
        uint32_t node;
        float tEntry;
    };
    std::array<Entry, kStackCapacity> stack;
    size_t size = 0;
    float tEntry = 0.0f;
    if (enterBox(nodes_[0].bounds, slabs, ray.tMin, ray.tMax, tEntry)) stack[size++] = {0, tEntry};
    while (size > 0) {
        const Entry entry = stack[--size];
        // The closest hit may have come nearer since the node was pushed.
        if (entry.tEntry > best.t) continue;
        const Node& node = nodes_[entry.node];
        if (isLeaf(node)) {
            for (uint32_t slot = node.first; slot < node.first + node.count; ++slot) {
                if (!enterBox(slotBoxes_[slot], slabs, ray.tMin, best.t, tEntry)) continue;
                const uint32_t instance = order_[slot];
                const std::optional<float> t = test(instance, tEntry, best.t);
                if (t && *t >= ray.tMin && isCloser(*t, instance, best)) best = {instance, *t};
            }
            continue;
        }
        float tA = 0.0f;
        float tB = 0.0f;
        const bool hitA = enterBox(nodes_[node.first].bounds, slabs, ray.tMin, best.t, tA);
        const bool hitB = enterBox(nodes_[node.first + 1].bounds, slabs, ray.tMin, best.t, tB);
        // The nearer child goes on top, so its hits shorten the ray before the other is searched.
        const Entry a{node.first, tA};
        const Entry b{node.first + 1, tB};
        if (hitA && hitB) {
            stack[size++] = tA <= tB ? b : a;
            stack[size++] = tA <= tB ? a : b;
        } else if (hitA) {
            stack[size++] = a;
        } else if (hitB) {
            stack[size++] = b;
        }
    }
    if (best.instance == kNoNode) return std::nullopt;
    return best;
}

std::optional<RayHit> InstanceBvh::closestHit(const Ray& ray) const
{
    return closestHitWith(ray, [](uint32_t, float tEntry, float) { return std::optional<float>(tEntry); });
}

std::optional<RayHit> InstanceBvh::closestHit(const Ray& ray, const InstanceRayTest& test) const
{
    if (!test) throw Error("InstanceBvh::closestHit: the instance test is empty; pass a callable");
    return closestHitWith(ray, [&](uint32_t instance, float, float tMax) {
        Ray shortened = ray;
        shortened.tMax = tMax;
        return test(instance, shortened);
    });
}

void InstanceBvh::findAllHits(const Ray& ray, std::vector<RayHit>& hits) const
{
    hits.clear();
    if (nodes_.empty() || !isUsable(ray)) return;
    const RaySlabs slabs(ray);
    std::array<uint32_t, kStackCapacity> stack;
    size_t size = 0;
    stack[size++] = 0;
    float tEntry = 0.0f;
    while (size > 0) {
        const Node& node = nodes_[stack[--size]];
        if (!enterBox(node.bounds, slabs, ray.tMin, ray.tMax, tEntry)) continue;
        if (isLeaf(node)) {
            for (uint32_t slot = node.first; slot < node.first + node.count; ++slot) {
                if (enterBox(slotBoxes_[slot], slabs, ray.tMin, ray.tMax, tEntry)) hits.push_back({order_[slot], tEntry});
            }
        } else {
            stack[size++] = node.first + 1;
            stack[size++] = node.first;
        }
    }
    std::sort(hits.begin(), hits.end(), [](const RayHit& a, const RayHit& b) { return isCloser(a.t, a.instance, b); });
}

void InstanceBvh::traverseFrontToBack(const glm::vec3& point, const BvhNodeVisitor& visit) const
{
    if (!visit) throw Error("InstanceBvh::traverseFrontToBack: the visitor is empty; pass a callable");
    if (nodes_.empty() || !isFinite(point)) return;
    struct Entry {
        float distanceSq;
        uint32_t node;
    };
    // A min-heap on (distance, node). A child's box lies within its parent's, so it is at
    // least as far: popping the nearest never goes back in distance (CHC++'s traversal
    // queue). A heap rather than a sorted descent, since siblings' subtrees interleave.
    const auto farther = [](const Entry& a, const Entry& b) {
        return a.distanceSq > b.distanceSq || (a.distanceSq == b.distanceSq && a.node > b.node);
    };
    std::vector<Entry> heap;
    heap.reserve(kStackCapacity);
    const auto push = [&](uint32_t node) {
        if (nodes_[node].bounds.empty()) return;
        heap.push_back({distanceSq(point, nodes_[node].bounds), node});
        std::push_heap(heap.begin(), heap.end(), farther);
    };
    push(0);
    while (!heap.empty()) {
        std::pop_heap(heap.begin(), heap.end(), farther);
        const Entry entry = heap.back();
        heap.pop_back();
        const Node& node = nodes_[entry.node];
        const bool leaf = isLeaf(node);
        const BvhNodeVisit nodeVisit{entry.node, parents_[entry.node], node.bounds, entry.distanceSq,
                                     leaf ? std::span(order_).subspan(node.first, node.count)
                                          : std::span<const uint32_t>()};
        if (!visit(nodeVisit) || leaf) continue;
        push(node.first);
        push(node.first + 1);
    }
}

std::vector<Aabb> instanceWorldBounds(std::span<const Instance> instances)
{
    std::vector<Aabb> bounds;
    bounds.reserve(instances.size());
    for (const Instance& instance : instances) bounds.push_back(instance.worldBounds);
    return bounds;
}

} // namespace penumbra::scene
