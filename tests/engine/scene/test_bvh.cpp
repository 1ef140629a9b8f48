// InstanceBvh against brute force over the same boxes: every query on random scenes of
// mixed boxes (points, flat and huge ones among them), degenerate inputs, refits.
#include "TestConfigs.h"

#include "penumbra/core/Error.h"
#include "penumbra/render/Projection.h"
#include "penumbra/scene/Bvh.h"
#include "penumbra/scene/Generators.h"

#include <glm/gtc/matrix_transform.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <iterator>
#include <map>
#include <numeric>
#include <random>
#include <set>
#include <string>

using namespace penumbra;
using test::kInf;
using test::kNaN;
using namespace penumbra::scene;

namespace {


Aabb box(glm::vec3 min, glm::vec3 max) { return Aabb{min, max}; }

// Boxes in a cube of edge 100 around the origin: edges log-uniform in [0.01, 10] per
// axis, and one box in twenty each a point, flat (one zero edge) or huge (edge 30 to 60).
std::vector<Aabb> randomBoxes(uint32_t count, uint32_t seed)
{
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> position(-50.0f, 50.0f);
    std::uniform_real_distribution<float> logEdge(-2.0f, 1.0f);
    std::uniform_real_distribution<float> hugeEdge(30.0f, 60.0f);
    std::uniform_int_distribution<int> kind(0, 19);
    std::uniform_int_distribution<int> axis(0, 2);
    std::vector<Aabb> boxes;
    for (uint32_t i = 0; i < count; ++i) {
        const glm::vec3 center{position(rng), position(rng), position(rng)};
        glm::vec3 edge{std::pow(10.0f, logEdge(rng)), std::pow(10.0f, logEdge(rng)), std::pow(10.0f, logEdge(rng))};
        switch (kind(rng)) {
        case 0: edge = glm::vec3(0.0f); break;
        case 1: edge[axis(rng)] = 0.0f; break;
        case 2: edge = glm::vec3(hugeEdge(rng)); break;
        default: break;
        }
        boxes.push_back(box(center - 0.5f * edge, center + 0.5f * edge));
    }
    return boxes;
}

// The tests' own rule for which boxes take part, written independently of the BVH's.
bool placeable(const Aabb& b)
{
    for (int a = 0; a < 3; ++a) {
        if (!std::isfinite(b.min[a]) || !std::isfinite(b.max[a]) || b.min[a] > b.max[a]) return false;
    }
    return true;
}

std::vector<uint32_t> sorted(std::vector<uint32_t> v)
{
    std::sort(v.begin(), v.end());
    return v;
}

// --- Brute force: every box, textbook formulas ------------------------------------------

std::vector<uint32_t> bruteFrustum(const std::vector<Aabb>& boxes, const Frustum& frustum)
{
    std::vector<uint32_t> out;
    for (uint32_t i = 0; i < boxes.size(); ++i) {
        const Aabb& b = boxes[i];
        if (!placeable(b)) continue;
        bool outside = false;
        for (uint32_t p = 0; p < frustum.planeCount; ++p) {
            const glm::vec4& plane = frustum.planes[p];
            // The corner farthest along the normal.
            const glm::vec3 corner = glm::mix(b.min, b.max, glm::vec3(glm::greaterThanEqual(glm::vec3(plane), glm::vec3(0.0f))));
            outside = outside || plane.x * corner.x + plane.y * corner.y + plane.z * corner.z + plane.w < 0.0f;
        }
        if (!outside) out.push_back(i);
    }
    return out;
}

std::vector<uint32_t> bruteOverlap(const std::vector<Aabb>& boxes, const Aabb& query)
{
    std::vector<uint32_t> out;
    for (uint32_t i = 0; i < boxes.size(); ++i) {
        const Aabb& b = boxes[i];
        if (placeable(b) && glm::all(glm::lessThanEqual(b.min, query.max)) && glm::all(glm::lessThanEqual(query.min, b.max))) {
            out.push_back(i);
        }
    }
    return out;
}

// Slab test: entry t, or nothing. Same float operations as any slab test, so results
// agree bit for bit with the BVH's for rays not parallel to an axis.
std::optional<float> bruteEnter(const Aabb& b, const Ray& ray)
{
    if (!placeable(b)) return std::nullopt;
    float tNear = ray.tMin;
    float tFar = ray.tMax;
    for (int a = 0; a < 3; ++a) {
        const float inv = 1.0f / ray.direction[a];
        const float t0 = (b.min[a] - ray.origin[a]) * inv;
        const float t1 = (b.max[a] - ray.origin[a]) * inv;
        tNear = std::max(tNear, std::min(t0, t1));
        tFar = std::min(tFar, std::max(t0, t1));
    }
    if (tNear > tFar) return std::nullopt;
    return tNear;
}

std::vector<RayHit> bruteAllHits(const std::vector<Aabb>& boxes, const Ray& ray)
{
    std::vector<RayHit> hits;
    for (uint32_t i = 0; i < boxes.size(); ++i) {
        if (const std::optional<float> t = bruteEnter(boxes[i], ray)) hits.push_back({i, *t});
    }
    std::sort(hits.begin(), hits.end(), [](const RayHit& a, const RayHit& b) {
        return a.t < b.t || (a.t == b.t && a.instance < b.instance);
    });
    return hits;
}

// --- Random queries -----------------------------------------------------------------------

glm::vec3 randomPoint(std::mt19937& rng, float halfEdge)
{
    std::uniform_real_distribution<float> u(-halfEdge, halfEdge);
    return {u(rng), u(rng), u(rng)};
}

Frustum randomFrustum(std::mt19937& rng)
{
    std::uniform_real_distribution<float> fov(20.0f, 100.0f);
    Camera camera;
    camera.position = randomPoint(rng, 80.0f);
    camera.target = randomPoint(rng, 30.0f);
    camera.fovYDeg = fov(rng);
    camera.nearWorld = 0.1f;
    return frustumFromViewProj(render::cameraViewProj(camera, 16.0f / 9.0f));
}

Ray randomRay(std::mt19937& rng)
{
    std::normal_distribution<float> gauss;
    Ray ray;
    ray.origin = randomPoint(rng, 70.0f);
    ray.direction = glm::normalize(glm::vec3(gauss(rng), gauss(rng), gauss(rng)));
    // Some rays end inside the scene.
    ray.tMax = std::uniform_int_distribution<int>(0, 3)(rng) == 0 ? 40.0f : kInf;
    return ray;
}

Aabb randomQueryBox(std::mt19937& rng)
{
    std::uniform_real_distribution<float> edge(0.0f, 20.0f);
    const glm::vec3 center = randomPoint(rng, 60.0f);
    const glm::vec3 half{edge(rng), edge(rng), edge(rng)};
    return box(center - half, center + half);
}

void expectSameHits(const std::vector<RayHit>& actual, const std::vector<RayHit>& expected)
{
    ASSERT_EQ(actual.size(), expected.size());
    for (size_t i = 0; i < actual.size(); ++i) {
        EXPECT_EQ(actual[i].instance, expected[i].instance) << "hit " << i;
        EXPECT_EQ(actual[i].t, expected[i].t) << "hit " << i;
    }
}

// Every query of `bvh` against brute force over `boxes`.
void expectQueriesMatchBruteForce(const InstanceBvh& bvh, const std::vector<Aabb>& boxes, uint32_t seed)
{
    ASSERT_EQ(bvh.instanceCount(), boxes.size());
    std::mt19937 rng(seed);
    std::vector<uint32_t> found;
    for (int i = 0; i < 20; ++i) {
        const Frustum frustum = randomFrustum(rng);
        bvh.cullFrustum(frustum, found);
        EXPECT_EQ(sorted(found), bruteFrustum(boxes, frustum)) << "frustum " << i;
    }
    for (int i = 0; i < 50; ++i) {
        const Aabb query = randomQueryBox(rng);
        bvh.findOverlapping(query, found);
        EXPECT_EQ(sorted(found), bruteOverlap(boxes, query)) << "overlap box " << i;
    }
    std::vector<RayHit> hits;
    for (int i = 0; i < 100; ++i) {
        SCOPED_TRACE("ray " + std::to_string(i));
        const Ray ray = randomRay(rng);
        const std::vector<RayHit> expected = bruteAllHits(boxes, ray);
        bvh.findAllHits(ray, hits);
        expectSameHits(hits, expected);
        const std::optional<RayHit> closest = bvh.closestHit(ray);
        ASSERT_EQ(closest.has_value(), !expected.empty());
        if (closest) {
            EXPECT_EQ(closest->instance, expected.front().instance);
            EXPECT_EQ(closest->t, expected.front().t);
        }
    }
}

struct Visit {
    uint32_t node;
    uint32_t parent;
    Aabb bounds;
    float distanceSq;
    std::vector<uint32_t> instances;
};

std::vector<Visit> visitAll(const InstanceBvh& bvh, const glm::vec3& point)
{
    std::vector<Visit> visits;
    bvh.traverseFrontToBack(point, [&](const BvhNodeVisit& v) {
        visits.push_back({v.node, v.parent, v.bounds, v.distanceSq, {v.instances.begin(), v.instances.end()}});
        return true;
    });
    return visits;
}

// Levels below the root of the deepest node.
uint32_t treeDepth(const InstanceBvh& bvh, const glm::vec3& anyPoint)
{
    std::map<uint32_t, uint32_t> depth;
    uint32_t deepest = 0;
    for (const Visit& v : visitAll(bvh, anyPoint)) {
        depth[v.node] = v.parent == InstanceBvh::kNoNode ? 0 : depth.at(v.parent) + 1;
        deepest = std::max(deepest, depth[v.node]);
    }
    return deepest;
}

std::vector<Aabb> moved(std::vector<Aabb> boxes, uint32_t seed, float maxShift, std::vector<uint32_t>& changed)
{
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> shift(-maxShift, maxShift);
    changed.clear();
    for (uint32_t i = 0; i < boxes.size(); ++i) {
        if (std::uniform_int_distribution<int>(0, 3)(rng) != 0) continue;
        const glm::vec3 d{shift(rng), shift(rng), shift(rng)};
        boxes[i] = box(boxes[i].min + d, boxes[i].max + d);
        changed.push_back(i);
    }
    return boxes;
}

} // namespace

// --- Random scenes ------------------------------------------------------------------------

class BvhRandomScene : public testing::TestWithParam<uint32_t> {};

INSTANTIATE_TEST_SUITE_P(Sizes, BvhRandomScene, testing::Values(1u, 100u, 5000u));

TEST_P(BvhRandomScene, QueriesMatchBruteForce)
{
    const std::vector<Aabb> boxes = randomBoxes(GetParam(), 7);
    const InstanceBvh bvh(boxes);
    EXPECT_LE(bvh.nodeCount(), 2 * boxes.size() - 1);
    expectQueriesMatchBruteForce(bvh, boxes, 11);
}

TEST_P(BvhRandomScene, FrontToBackVisitsEveryLeafNearestFirst)
{
    const std::vector<Aabb> boxes = randomBoxes(GetParam(), 8);
    const InstanceBvh bvh(boxes);
    std::mt19937 rng(12);
    for (int i = 0; i < 5; ++i) {
        const glm::vec3 point = randomPoint(rng, 70.0f);
        const std::vector<Visit> visits = visitAll(bvh, point);
        ASSERT_EQ(visits.size(), bvh.nodeCount());
        std::set<uint32_t> visited;
        std::vector<uint32_t> leafInstances;
        for (size_t v = 0; v < visits.size(); ++v) {
            const Visit& visit = visits[v];
            EXPECT_TRUE(visited.insert(visit.node).second) << "node " << visit.node << " visited twice";
            if (visit.parent != InstanceBvh::kNoNode) {
                EXPECT_TRUE(visited.count(visit.parent)) << "child before parent";
            }
            if (v > 0) {
                EXPECT_GE(visit.distanceSq, visits[v - 1].distanceSq) << "visit " << v;
            }
            const glm::vec3 outside = glm::max(glm::max(visit.bounds.min - point, point - visit.bounds.max), glm::vec3(0.0f));
            EXPECT_NEAR(visit.distanceSq, glm::dot(outside, outside), 1e-4f * (1.0f + visit.distanceSq));
            for (uint32_t instance : visit.instances) {
                leafInstances.push_back(instance);
                EXPECT_TRUE(glm::all(glm::lessThanEqual(visit.bounds.min, boxes[instance].min)) &&
                            glm::all(glm::lessThanEqual(boxes[instance].max, visit.bounds.max)))
                    << "instance " << instance << " sticks out of its leaf";
            }
        }
        std::vector<uint32_t> all(boxes.size());
        std::iota(all.begin(), all.end(), 0u);
        EXPECT_EQ(sorted(leafInstances), all);
    }
}

TEST_P(BvhRandomScene, FrontToBackSkipsRejectedSubtrees)
{
    const std::vector<Aabb> boxes = randomBoxes(GetParam(), 9);
    const InstanceBvh bvh(boxes);
    std::mt19937 rng(13);
    for (int i = 0; i < 10; ++i) {
        const Aabb query = randomQueryBox(rng);
        std::set<uint32_t> accepted;
        std::vector<uint32_t> seen;
        size_t visits = 0;
        bvh.traverseFrontToBack(randomPoint(rng, 70.0f), [&](const BvhNodeVisit& v) {
            ++visits;
            EXPECT_TRUE(v.parent == InstanceBvh::kNoNode || accepted.count(v.parent))
                << "node " << v.node << " visited below a rejected node";
            const bool keep = glm::all(glm::lessThanEqual(v.bounds.min, query.max)) &&
                              glm::all(glm::lessThanEqual(query.min, v.bounds.max));
            if (keep) accepted.insert(v.node);
            for (uint32_t instance : v.instances) seen.push_back(instance);
            return keep;
        });
        const std::vector<uint32_t> expected = bruteOverlap(boxes, query);
        const std::vector<uint32_t> visited = sorted(seen);
        std::vector<uint32_t> missing;
        std::set_difference(expected.begin(), expected.end(), visited.begin(), visited.end(),
                            std::back_inserter(missing));
        EXPECT_TRUE(missing.empty()) << missing.size() << " overlapping instances never visited";
        if (GetParam() > 1000) {
            EXPECT_LT(visits, bvh.nodeCount() / 2);
        }
    }
}

TEST_P(BvhRandomScene, RefitAfterRandomMovesAnswersLikeARebuild)
{
    const std::vector<Aabb> boxes = randomBoxes(GetParam(), 10);
    InstanceBvh full(boxes);
    InstanceBvh subset(boxes);
    std::vector<uint32_t> changed;
    const std::vector<Aabb> after = moved(boxes, 14, 20.0f, changed);
    full.refit(after);
    subset.refit(after, changed);
    expectQueriesMatchBruteForce(full, after, 15);
    expectQueriesMatchBruteForce(subset, after, 15);
    expectQueriesMatchBruteForce(InstanceBvh(after), after, 15);
    // Refitting a subset leaves every node box as a full refit does.
    EXPECT_EQ(subset.sahCost(), full.sahCost());
}

// --- Degenerate inputs --------------------------------------------------------------------

TEST(Bvh, EmptyTreeFindsNothing)
{
    InstanceBvh bvh;
    EXPECT_EQ(bvh.instanceCount(), 0u);
    EXPECT_EQ(bvh.nodeCount(), 0u);
    EXPECT_EQ(bvh.sahCost(), 0.0);
    std::vector<uint32_t> found{42};
    std::mt19937 rng(1);
    bvh.cullFrustum(randomFrustum(rng), found);
    EXPECT_TRUE(found.empty());
    bvh.findOverlapping(box(glm::vec3(-1e9f), glm::vec3(1e9f)), found);
    EXPECT_TRUE(found.empty());
    EXPECT_FALSE(bvh.closestHit(randomRay(rng)));
    bool visited = false;
    bvh.traverseFrontToBack(glm::vec3(0.0f), [&](const BvhNodeVisit&) { return visited = true; });
    EXPECT_FALSE(visited);
    bvh.refit(std::vector<Aabb>{});
    EXPECT_EQ(bvh.refitOrRebuild(std::vector<Aabb>{}).action, RefitAction::Refitted);
    expectQueriesMatchBruteForce(InstanceBvh(std::vector<Aabb>{}), {}, 2);
}

TEST(Bvh, SingleInstanceIsFound)
{
    const std::vector<Aabb> boxes{box({1, 2, 3}, {2, 3, 4})};
    const InstanceBvh bvh(boxes);
    EXPECT_EQ(bvh.nodeCount(), 1u);
    const std::optional<RayHit> hit = bvh.closestHit({{1.5f, 2.5f, -6.0f}, {0, 0, 2}});
    ASSERT_TRUE(hit);
    EXPECT_EQ(hit->instance, 0u);
    EXPECT_FLOAT_EQ(hit->t, 4.5f);  // in multiples of the direction's length
    std::vector<uint32_t> found;
    bvh.findOverlapping(box({2, 3, 4}, {5, 5, 5}), found);  // touching a corner
    EXPECT_EQ(found, std::vector<uint32_t>{0});
    expectQueriesMatchBruteForce(bvh, boxes, 3);
}

TEST(Bvh, IdenticalCentroidsSplitAtTheMedian)
{
    // Nested boxes around one centre, then the same box many times: nothing for SAH bins
    // to separate.
    std::vector<Aabb> nested;
    for (int i = 1; i <= 1000; ++i) nested.push_back(box(glm::vec3(5.0f - 0.01f * i), glm::vec3(5.0f + 0.01f * i)));
    std::vector<Aabb> same(1000, box({-1, 0, 2}, {3, 4, 5}));
    for (const std::vector<Aabb>* boxes : {&nested, &same}) {
        const InstanceBvh bvh(*boxes);
        // Halving 1000 down to leaves of at most 4 takes 8 levels.
        EXPECT_LE(treeDepth(bvh, glm::vec3(0.0f)), 8u);
        expectQueriesMatchBruteForce(bvh, *boxes, 4);
    }
}

TEST(Bvh, BoxesWithoutAreaKeepTheTreeShallow)
{
    // Points along a line with spacing growing geometrically, then segments on it: every
    // box and every node has zero area, so the SAH cannot rank splits.
    std::vector<Aabb> points;
    std::vector<Aabb> segments;
    for (int i = 0; i < 5000; ++i) {
        const glm::vec3 p{std::pow(1.003f, float(i)) - 1.0f, 2.0f, -3.0f};
        points.push_back(box(p, p));
        segments.push_back(box(p, p + glm::vec3(0.5f, 0.0f, 0.0f)));
    }
    for (const std::vector<Aabb>* boxes : {&points, &segments}) {
        const InstanceBvh bvh(*boxes);
        EXPECT_LE(treeDepth(bvh, glm::vec3(0.0f)), 11u);  // ceil(log2(5000 / 4))
        expectQueriesMatchBruteForce(bvh, *boxes, 5);
        // Rays along the line run in the boxes' face planes, and hit every box ahead.
        std::vector<RayHit> hits;
        bvh.findAllHits({{-1.0f, 2.0f, -3.0f}, {1, 0, 0}}, hits);
        EXPECT_EQ(hits.size(), boxes->size());
    }
}

TEST(Bvh, UnplaceableBoxesAreNeverReturned)
{
    std::vector<Aabb> boxes = randomBoxes(2000, 16);
    const std::vector<Aabb> unplaceable{
        Aabb{},
        box({kNaN, 0, 0}, {1, 1, 1}),
        box({0, 0, 0}, {1, kNaN, 1}),
        box(glm::vec3(kNaN), glm::vec3(kNaN)),
        box({-kInf, 0, 0}, {1, 1, 1}),
        box(glm::vec3(-kInf), glm::vec3(kInf)),
        box({0, 0, 1}, {1, 1, 0}),  // min > max in z only
    };
    std::mt19937 rng(17);
    std::vector<uint32_t> bad;
    for (uint32_t i = 0; i < boxes.size(); i += 7) {
        boxes[i] = unplaceable[std::uniform_int_distribution<size_t>(0, unplaceable.size() - 1)(rng)];
        bad.push_back(i);
    }
    InstanceBvh bvh(boxes);
    expectQueriesMatchBruteForce(bvh, boxes, 18);

    // A frustum that holds the whole scene takes the path that keeps whole subtrees.
    Camera camera;
    camera.position = {0, 0, 1000};
    camera.target = {0, 0, 0};
    camera.fovYDeg = 30.0f;
    const Frustum everything = frustumFromViewProj(render::cameraViewProj(camera, 1.0f));
    std::vector<uint32_t> found;
    bvh.cullFrustum(everything, found);
    EXPECT_EQ(sorted(found), bruteFrustum(boxes, everything));
    EXPECT_EQ(found.size(), boxes.size() - bad.size());

    // Refits move boxes in and out: bad ones get real boxes, some good ones go bad.
    std::vector<Aabb> refitted = boxes;
    const std::vector<Aabb> fresh = randomBoxes(uint32_t(boxes.size()), 19);
    for (uint32_t i : bad) refitted[i] = fresh[i];
    for (uint32_t i = 3; i < boxes.size(); i += 11) refitted[i] = box({kNaN, 1, 1}, {2, 2, 2});
    bvh.refit(refitted);
    expectQueriesMatchBruteForce(bvh, refitted, 20);
    // Front to back: nodes without a box are passed over, and every placeable instance
    // is in a visited leaf.
    std::vector<uint32_t> listed;
    bvh.traverseFrontToBack(glm::vec3(0.0f), [&](const BvhNodeVisit& v) {
        EXPECT_FALSE(v.bounds.empty()) << "node " << v.node;
        listed.insert(listed.end(), v.instances.begin(), v.instances.end());
        return true;
    });
    for (uint32_t i = 0; i < refitted.size(); ++i) {
        if (placeable(refitted[i])) {
            EXPECT_EQ(std::count(listed.begin(), listed.end(), i), 1) << "instance " << i;
        }
    }

    // A tree of nothing but unplaceable boxes.
    const InstanceBvh none(unplaceable);
    none.cullFrustum(everything, found);
    EXPECT_TRUE(found.empty());
    bool visited = false;
    none.traverseFrontToBack(glm::vec3(0.0f), [&](const BvhNodeVisit&) { return visited = true; });
    EXPECT_FALSE(visited);
    expectQueriesMatchBruteForce(none, unplaceable, 21);
}

TEST(Bvh, NonFiniteQueriesFindNothing)
{
    const std::vector<Aabb> boxes = randomBoxes(500, 22);
    const InstanceBvh bvh(boxes);
    std::vector<uint32_t> found;
    for (const Aabb& query : {box(glm::vec3(kNaN), glm::vec3(1e9f)), box(glm::vec3(-kInf), glm::vec3(kInf)),
                              box(glm::vec3(1.0f), glm::vec3(-1.0f))}) {
        bvh.findOverlapping(query, found);
        EXPECT_TRUE(found.empty());
    }
    std::vector<RayHit> hits;
    for (const Ray& ray : {Ray{glm::vec3(kNaN), {0, 0, 1}}, Ray{{0, 0, 0}, {kNaN, 0, 1}},
                           Ray{{0, 0, -kInf}, {0, 0, 1}}, Ray{{0, 0, 0}, {0, 0, 1}, kNaN},
                           Ray{{0, 0, 0}, {0, 0, 1}, 0.0f, kNaN}}) {
        EXPECT_FALSE(bvh.closestHit(ray));
        bvh.findAllHits(ray, hits);
        EXPECT_TRUE(hits.empty());
    }
    bool visited = false;
    bvh.traverseFrontToBack(glm::vec3(kNaN, 0, 0), [&](const BvhNodeVisit&) { return visited = true; });
    EXPECT_FALSE(visited);
    glm::mat4 viewProj(1.0f);
    viewProj[2][3] = kNaN;
    EXPECT_THROW(frustumFromViewProj(viewProj), Error);
}

TEST(Bvh, MisuseIsReported)
{
    const std::vector<Aabb> boxes = randomBoxes(10, 23);
    InstanceBvh bvh(boxes);
    EXPECT_THROW(bvh.refit(randomBoxes(11, 23)), Error);
    // A rejected refit changes nothing, not even the instances listed before the bad one.
    EXPECT_THROW(bvh.refit(randomBoxes(10, 24), std::vector<uint32_t>{3, 10}), Error);
    EXPECT_EQ(bvh.sahCost(), bvh.builtSahCost());
    EXPECT_THROW(bvh.closestHit(Ray{}, InstanceRayTest{}), Error);
    EXPECT_THROW(bvh.traverseFrontToBack(glm::vec3(0.0f), BvhNodeVisitor{}), Error);
    Frustum tooMany;
    tooMany.planeCount = 7;
    std::vector<uint32_t> found;
    EXPECT_THROW(bvh.cullFrustum(tooMany, found), Error);
}

// --- Frustum ------------------------------------------------------------------------------

TEST(Bvh, FrustumOfTheEngineProjectionHasNoFarPlane)
{
    Camera camera;
    camera.position = {3, 4, 5};
    camera.target = {0, 1, -2};
    camera.nearWorld = 0.25f;
    const Frustum frustum = frustumFromViewProj(render::cameraViewProj(camera, 1.5f));
    ASSERT_EQ(frustum.planeCount, 5u);
    for (uint32_t p = 0; p < frustum.planeCount; ++p) EXPECT_NEAR(glm::length(glm::vec3(frustum.planes[p])), 1.0f, 1e-6f);
    const auto inside = [&](const glm::vec3& point) {
        for (uint32_t p = 0; p < frustum.planeCount; ++p) {
            if (glm::dot(glm::vec3(frustum.planes[p]), point) + frustum.planes[p].w < 0.0f) return false;
        }
        return true;
    };
    const glm::vec3 forward = glm::normalize(camera.target - camera.position);
    EXPECT_TRUE(inside(camera.position + 0.26f * forward));
    EXPECT_FALSE(inside(camera.position + 0.24f * forward));  // before the near plane
    EXPECT_FALSE(inside(camera.position - forward));
    EXPECT_TRUE(inside(camera.position + 1e12f * forward));  // no far plane
}

TEST(Bvh, FrustumOfAFiniteReversedZProjectionKeepsItsFarPlane)
{
    // depth = A + B / viewDepth with depth(near) = 1, depth(far) = 0.
    const float nearWorld = 0.5f;
    const float farWorld = 100.0f;
    glm::mat4 proj = render::perspectiveReversedZ(glm::radians(60.0f), 1.0f, nearWorld);
    proj[2][2] = nearWorld / (farWorld - nearWorld);
    proj[3][2] = nearWorld * farWorld / (farWorld - nearWorld);
    const Frustum frustum = frustumFromViewProj(proj);
    ASSERT_EQ(frustum.planeCount, 6u);
    const InstanceBvh bvh(std::vector<Aabb>{box({-1, -1, -99}, {1, 1, -98}), box({-1, -1, -102}, {1, 1, -101})});
    std::vector<uint32_t> found;
    bvh.cullFrustum(frustum, found);
    EXPECT_EQ(found, std::vector<uint32_t>{0});
}

TEST(Bvh, FrustumKeepsEveryBoxThatTouchesIt)
{
    // Boxes around points inside the frustum must be kept, point boxes included; small
    // boxes around points outside it must go (or the test would pass by keeping all).
    Camera camera;
    camera.position = {10, 20, 30};
    camera.target = {0, 0, 0};
    camera.fovYDeg = 50.0f;
    camera.nearWorld = 0.1f;
    const glm::mat4 viewProj = render::cameraViewProj(camera, 2.0f);
    const glm::mat4 clipToWorld = glm::inverse(viewProj);
    std::mt19937 rng(24);
    std::uniform_real_distribution<float> ndcInside(-0.98f, 0.98f);
    std::uniform_real_distribution<float> ndcOutside(1.05f, 3.0f);
    std::uniform_real_distribution<float> logDepth(-6.0f, -0.01f);  // depth 1e-6: a million near distances away
    std::vector<Aabb> boxes;
    std::vector<bool> touches;
    for (int i = 0; i < 4000; ++i) {
        const bool in = i % 2 == 0;
        glm::vec2 ndc{ndcInside(rng), ndcInside(rng)};
        if (!in) ndc[i % 4 / 2] = (i % 8 < 4 ? 1.0f : -1.0f) * ndcOutside(rng);
        const glm::vec4 clip = clipToWorld * glm::vec4(ndc, std::pow(10.0f, logDepth(rng)), 1.0f);
        const glm::vec3 p = glm::vec3(clip) / clip.w;
        const float half = i % 3 == 0 ? 0.0f : 1e-3f * glm::length(p - camera.position);
        boxes.push_back(box(p - half, p + half));
        touches.push_back(in);
    }
    const InstanceBvh bvh(boxes);
    std::vector<uint32_t> found;
    bvh.cullFrustum(frustumFromViewProj(viewProj), found);
    const std::set<uint32_t> kept(found.begin(), found.end());
    for (uint32_t i = 0; i < boxes.size(); ++i) EXPECT_EQ(kept.count(i) == 1, bool(touches[i])) << "box " << i;
}

// --- Rays ---------------------------------------------------------------------------------

TEST(Bvh, RaysAlongFacesAndParallelToSlabs)
{
    const std::vector<Aabb> boxes{box({0, 0, 0}, {1, 1, 1}), box({3, 3, 3}, {3, 3, 3}), box({5, 5, 2}, {6, 6, 2})};
    const InstanceBvh bvh(boxes);
    struct Case {
        const char* what;
        Ray ray;
        std::optional<uint32_t> instance;
        float t;
    };
    const Case cases[] = {
        {"in the face plane x = 0", {{0, 0.5f, -5}, {0, 0, 1}}, 0u, 5.0f},
        {"along an edge", {{0, 0, -5}, {0, 0, 1}}, 0u, 5.0f},
        {"through the middle", {{0.5f, 0.5f, -5}, {0, 0, 1}}, 0u, 5.0f},
        {"beside it", {{2, 0.5f, -5}, {0, 0, 1}}, std::nullopt, 0.0f},
        {"pointing away", {{0.5f, 0.5f, -5}, {0, 0, -1}}, std::nullopt, 0.0f},
        {"negative zero components", {{0.5f, 0.5f, -5}, {-0.0f, -0.0f, 1}}, 0u, 5.0f},
        {"from inside", {{0.5f, 0.5f, 0.5f}, {1, 0, 0}}, 0u, 0.0f},
        {"ending short of it", {{0.5f, 0.5f, -5}, {0, 0, 1}, 0.0f, 4.9f}, std::nullopt, 0.0f},
        {"ending on its face", {{0.5f, 0.5f, -5}, {0, 0, 1}, 0.0f, 5.0f}, 0u, 5.0f},
        {"starting past it", {{0.5f, 0.5f, -5}, {0, 0, 1}, 6.5f}, std::nullopt, 0.0f},
        {"through a point box", {{3, 3, -10}, {0, 0, 1}}, 1u, 13.0f},
        {"through a flat box", {{5.5f, 5.5f, 0}, {0, 0, 1}}, 2u, 2.0f},
        {"skimming a flat box's plane", {{4, 5.5f, 2}, {1, 0, 0}}, 2u, 1.0f},
    };
    for (const Case& c : cases) {
        const std::optional<RayHit> hit = bvh.closestHit(c.ray);
        ASSERT_EQ(hit.has_value(), c.instance.has_value()) << c.what;
        if (!hit) continue;
        EXPECT_EQ(hit->instance, *c.instance) << c.what;
        EXPECT_FLOAT_EQ(hit->t, c.t) << c.what;
    }
}

TEST_P(BvhRandomScene, ClosestHitWithInstanceTestFindsTheNearestSphere)
{
    // Each instance is the sphere inscribed in its box; the test intersects it exactly.
    const std::vector<Aabb> boxes = randomBoxes(GetParam(), 25);
    const auto hitSphere = [&](uint32_t instance, const Ray& ray) -> std::optional<float> {
        const Aabb& b = boxes[instance];
        const glm::dvec3 center = 0.5 * (glm::dvec3(b.min) + glm::dvec3(b.max));
        const glm::dvec3 e = glm::dvec3(b.max) - glm::dvec3(b.min);
        const double radius = 0.5 * std::min({e.x, e.y, e.z});
        const glm::dvec3 d(ray.direction);
        const glm::dvec3 oc = glm::dvec3(ray.origin) - center;
        const double a = glm::dot(d, d);
        const double halfB = glm::dot(oc, d);
        const double disc = halfB * halfB - a * (glm::dot(oc, oc) - radius * radius);
        if (disc < 0.0) return std::nullopt;
        for (const double t : {(-halfB - std::sqrt(disc)) / a, (-halfB + std::sqrt(disc)) / a}) {
            if (t >= ray.tMin && t <= ray.tMax) return float(t);
        }
        return std::nullopt;
    };
    const InstanceBvh bvh(boxes);
    std::mt19937 rng(26);
    size_t tested = 0;
    size_t boxHits = 0;
    for (int i = 0; i < 300; ++i) {
        const Ray ray = randomRay(rng);
        std::optional<RayHit> expected;
        for (uint32_t instance = 0; instance < boxes.size(); ++instance) {
            const std::optional<float> t = hitSphere(instance, ray);
            if (t && (!expected || *t < expected->t)) expected = RayHit{instance, *t};
        }
        boxHits += bruteAllHits(boxes, ray).size();
        const std::optional<RayHit> hit = bvh.closestHit(ray, [&](uint32_t instance, const Ray& shortened) {
            ++tested;
            return hitSphere(instance, shortened);
        });
        ASSERT_EQ(hit.has_value(), expected.has_value()) << "ray " << i;
        if (hit) {
            EXPECT_EQ(hit->instance, expected->instance) << "ray " << i;
            EXPECT_EQ(hit->t, expected->t) << "ray " << i;
        }
    }
    // Hits shorten the ray, so boxes behind the closest sphere are never tested.
    if (GetParam() > 1000) {
        EXPECT_LT(tested, boxHits / 2);
    }
}

// --- Refit and rebuild --------------------------------------------------------------------

TEST(Bvh, ScatteredBoxesTriggerARebuild)
{
    std::vector<Aabb> boxes = randomBoxes(5000, 27);
    InstanceBvh bvh(boxes);
    const double built = bvh.builtSahCost();
    EXPECT_EQ(bvh.sahCost(), built);

    // Animation jitter: every box moves by up to 0.1 in a scene of edge 100.
    std::vector<uint32_t> changed;
    const std::vector<Aabb> jittered = moved(boxes, 28, 0.1f, changed);
    const RefitReport jitter = bvh.refitOrRebuild(jittered, changed);
    EXPECT_EQ(jitter.action, RefitAction::Refitted);
    EXPECT_EQ(jitter.builtSahCost, built);
    EXPECT_LT(jitter.refitSahCost, 1.1 * built);

    // Scattered: the boxes trade places, so every leaf spans the scene.
    std::vector<Aabb> scattered = jittered;
    std::shuffle(scattered.begin(), scattered.end(), std::mt19937(29));
    const RefitReport scatter = bvh.refitOrRebuild(scattered);
    EXPECT_EQ(scatter.action, RefitAction::Rebuilt);
    EXPECT_GT(scatter.refitSahCost, InstanceBvh::kRebuildCostRatio * built);
    EXPECT_EQ(bvh.sahCost(), bvh.builtSahCost());
    EXPECT_LT(bvh.builtSahCost(), scatter.refitSahCost / 2.0);
    expectQueriesMatchBruteForce(bvh, scattered, 30);

    // A different instance count cannot be refitted.
    const RefitReport grown = bvh.refitOrRebuild(randomBoxes(5001, 31));
    EXPECT_EQ(grown.action, RefitAction::Rebuilt);
    EXPECT_EQ(bvh.instanceCount(), 5001u);
}

TEST(Bvh, FollowsSceneUpdates)
{
    Scene scene = generateBoxGrid(BoxGridParams{});
    InstanceBvh bvh(instanceWorldBounds(scene.instances));
    const uint32_t mover = 3;
    const Aabb before = scene.instances[mover].worldBounds;
    scene.graph.setLocal(scene.instances[mover].node, glm::translate(glm::mat4(1.0f), {100.0f, 0.0f, 0.0f}));
    const std::vector<uint32_t> changed = scene.updateTransforms();
    ASSERT_FALSE(changed.empty());
    const std::vector<Aabb> bounds = instanceWorldBounds(scene.instances);
    bvh.refit(bounds, changed);
    std::vector<uint32_t> found;
    bvh.findOverlapping(scene.instances[mover].worldBounds, found);
    EXPECT_TRUE(std::count(found.begin(), found.end(), mover));
    bvh.findOverlapping(before, found);
    EXPECT_FALSE(std::count(found.begin(), found.end(), mover));
    expectQueriesMatchBruteForce(bvh, bounds, 32);
}
