#include "TestConfigs.h"

#include "penumbra/core/Error.h"
#include "penumbra/scene/Generators.h"
#include "penumbra/scene/Scene.h"

#include <glm/gtc/matrix_transform.hpp>
#include <gtest/gtest.h>

using namespace penumbra;
using test::expectNear;
using namespace penumbra::scene;

namespace {

glm::mat4 translate(float x, float y, float z) { return glm::translate(glm::mat4(1.0f), {x, y, z}); }


} // namespace

TEST(SceneGraph, WorldIsParentTimesLocal)
{
    SceneGraph g;
    const uint32_t root = g.addNode("root", kNoParent, translate(1, 0, 0));
    const uint32_t child = g.addNode("child", int32_t(root), glm::scale(glm::mat4(1.0f), glm::vec3(2.0f)));
    const uint32_t grandchild = g.addNode("grandchild", int32_t(child), translate(0, 1, 0));
    expectNear(glm::vec3(g.world(grandchild) * glm::vec4(0, 0, 0, 1)), {1, 2, 0});
}

TEST(SceneGraph, MovingANodeMovesItsSubtreeOnly)
{
    SceneGraph g;
    const uint32_t a = g.addNode("a", kNoParent, glm::mat4(1.0f));
    const uint32_t b = g.addNode("b", int32_t(a), translate(0, 1, 0));
    const uint32_t c = g.addNode("c", int32_t(b), translate(0, 0, 1));
    const uint32_t other = g.addNode("other", kNoParent, translate(5, 0, 0));
    EXPECT_TRUE(g.update().empty());  // nothing moved since creation

    g.setLocal(b, translate(0, 3, 0));
    EXPECT_TRUE(g.dirty());
    const std::vector<uint32_t> moved = g.update();
    EXPECT_EQ(moved, (std::vector<uint32_t>{b, c}));
    EXPECT_FALSE(g.dirty());
    expectNear(glm::vec3(g.world(c)[3]), {0, 3, 1});
    expectNear(glm::vec3(g.world(other)[3]), {5, 0, 0});
    EXPECT_TRUE(g.update().empty());
}

TEST(SceneGraph, ParentMustExist)
{
    SceneGraph g;
    EXPECT_THROW(g.addNode("orphan", 0, glm::mat4(1.0f)), Error);
    g.addNode("root", kNoParent, glm::mat4(1.0f));
    EXPECT_THROW(g.addNode("self-or-later", 1, glm::mat4(1.0f)), Error);
    EXPECT_THROW(g.addNode("negative", -7, glm::mat4(1.0f)), Error);
}

TEST(Scene, InstanceBoundsFollowTheirNode)
{
    Scene s;
    Mesh box = makeBox("box");
    box.computeBounds();
    s.meshes.push_back(box);
    const uint32_t parent = s.graph.addNode("parent", kNoParent, glm::mat4(1.0f));
    const uint32_t node = s.graph.addNode("box", int32_t(parent), translate(10, 0, 0));
    const uint32_t still = s.graph.addNode("still", kNoParent, glm::mat4(1.0f));
    const uint32_t moving = s.addInstance(0, node);
    s.addInstance(0, still);
    expectNear(s.instances[moving].worldBounds.center(), {10, 0, 0});

    s.graph.setLocal(parent, translate(0, 4, 0));
    EXPECT_EQ(s.updateTransforms(), (std::vector<uint32_t>{moving}));
    expectNear(s.instances[moving].worldBounds.center(), {10, 4, 0});
    expectNear(s.instances[moving].worldBounds.extent(), {1, 1, 1});
    expectNear(s.bounds().max, {10.5f, 4.5f, 0.5f});
}

TEST(Scene, BoxGridIsDeterministicBySeed)
{
    const Scene a = generateBoxGrid({}), b = generateBoxGrid({});
    BoxGridParams other;
    other.seed = 2;
    const Scene c = generateBoxGrid(other);
    ASSERT_EQ(a.instances.size(), 27u);
    expectNear(a.bounds().max, b.bounds().max);
    EXPECT_EQ(a.instances[1].worldBounds.max.y, b.instances[1].worldBounds.max.y);
    EXPECT_NE(a.instances[1].worldBounds.max.y, c.instances[1].worldBounds.max.y);  // box heights differ
    EXPECT_EQ(a.triangleCount(), b.triangleCount());
}

TEST(Aabb, EmptyOnAnyInvertedAxis)
{
    EXPECT_TRUE(Aabb{}.empty());
    EXPECT_FALSE((Aabb{{0, 0, 0}, {0, 0, 0}}.empty()));  // a point is a box
    EXPECT_TRUE((Aabb{{0, 1, 0}, {1, 0, 1}}.empty()));   // inverted in y only
    EXPECT_TRUE((Aabb{{0, 0, 1}, {1, 1, 0}}.empty()));   // inverted in z only
    EXPECT_EQ((Aabb{{0, 1, 0}, {1, 0, 1}}.radius()), 0.0f);
}
