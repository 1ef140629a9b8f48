// Keeping what did not change (graph::PassBuilder::dependsOn, frame/FrameChanges.h): over
// frames where the camera, a light and casters move in turn - into, inside and out of the
// lights' views - and frames where nothing moves, every frame of the renderer that keeps
// passes equals, bit for bit, the frame of one that runs every pass (keep_unchanged
// false), for every technique that declares what it depends on and every light type; and
// the still frames really are kept.
#include "PluginFrame.h"
#include "TestConfigs.h"
#include "TestContext.h"

#include "penumbra/config/Config.h"
#include "penumbra/frame/FrameChanges.h"
#include "penumbra/frame/FrameRenderer.h"

#include <glm/gtc/matrix_transform.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

using namespace penumbra;

namespace {

struct KeepCase {
    const char* technique;
    test::LightCase light;
    // Where the casters drawn follow the camera, a camera move draws the maps again.
    config::CullingMode culling = config::CullingMode::None;
    bool focus = false;
};

std::ostream& operator<<(std::ostream& os, const KeepCase& c)
{
    return os << c.technique << "/" << c.light << "/" << config::cullingModeName(c.culling) << (c.focus ? "+focus" : "");
}

uint32_t nodeCalled(const scene::Scene& scene, const std::string& name)
{
    for (uint32_t n = 0; n < scene.graph.size(); ++n)
        if (scene.graph.node(n).name == name) return n;
    ADD_FAILURE() << "no node " << name;
    return 0;
}

// What a frame did: its colour, every light's V, and which passes ran.
struct Drawn {
    std::vector<uint8_t> color;
    std::vector<std::vector<float>> visibility;
    std::vector<std::string> ran, kept;
};

Drawn drawAndRead(frame::FrameRenderer& renderer)
{
    const frame::FrameTimings timings = renderer.renderFrame();
    Drawn d{renderer.readColor(), {}, {}, {}};
    for (size_t l = 0; l < renderer.lightCount(); ++l) d.visibility.push_back(renderer.readVisibility(l));
    for (const graph::PassTiming& pass : timings.passes) (pass.kept ? d.kept : d.ran).push_back(pass.name);
    return d;
}

bool anyNamedFrom(const std::vector<std::string>& names, const std::string& prefix)
{
    return std::any_of(names.begin(), names.end(), [&](const std::string& n) { return n.rfind(prefix, 0) == 0; });
}

class KeepUnchanged : public test::GpuTest, public ::testing::WithParamInterface<KeepCase> {};

} // namespace

TEST_P(KeepUnchanged, EveryFrameIsTheUncachedFrameAndStillFramesAreKept)
{
    const KeepCase& c = GetParam();
    config::RenderConfig config = test::defaultTestConfig();
    config.width = 96;
    config.height = 54;
    test::setLightType(config.lights[0], c.light.type);
    test::setShadow(config.lights[0], c.technique, {{"resolution", 256}});
    config.lights[0].shadow.required = true;
    config.culling = c.culling;
    config.shadowFocus = c.focus;
    // A second light, always hard: a light whose passes stay kept while the other's run.
    config::LightConfig second = test::defaultTestConfig().lights[0];
    second.name = "second";
    second.light.position = {6.0f, 14.0f, -8.0f};
    second.light.direction = glm::normalize(-second.light.position);
    test::setShadow(second, "hard", {{"resolution", 256}});
    config.lights.push_back(second);

    scene::Scene scene = config::buildScene(config);
    config::RenderConfig uncachedConfig = config;
    uncachedConfig.keepUnchanged = false;
    frame::FrameRenderer kept(*context, scene, config, test::plugins());
    frame::FrameRenderer uncached(*context, scene, uncachedConfig, test::plugins());

    const uint32_t box = nodeCalled(scene, "box_2_2");
    const glm::mat4 rest = scene.graph.local(box);
    enum class Change { None, Camera, CasterInView, Light, CasterOut, CasterBack };
    const Change script[] = {Change::None,      Change::None,     Change::Camera, Change::None,
                             Change::CasterInView, Change::Light, Change::None,   Change::CasterOut,
                             Change::None,      Change::CasterBack};
    int frameIndex = 0;
    for (const Change change : script) {
        SCOPED_TRACE(testing::Message() << c << ", frame " << frameIndex);
        std::vector<uint32_t> moved;
        switch (change) {
        case Change::None: break;
        case Change::Camera: config.camera.position += glm::vec3(0.7f, 0.4f, -0.5f); break;
        case Change::Light: config.lights[0].light.position += glm::vec3(0.6f, 0.3f, 0.4f); break;
        case Change::CasterInView:
            scene.graph.setLocal(box, glm::translate(glm::mat4(1.0f), glm::vec3(0.8f, 0.5f, 0.3f)) * rest);
            break;
        case Change::CasterOut:  // far below the ground: out of every view, the scene's box grows
            scene.graph.setLocal(box, glm::translate(glm::mat4(1.0f), glm::vec3(0.0f, -50.0f, 0.0f)) * rest);
            break;
        case Change::CasterBack: scene.graph.setLocal(box, rest); break;
        }
        moved = scene.updateTransforms();
        uncachedConfig = config;
        uncachedConfig.keepUnchanged = false;
        kept.update(config, scene, moved);
        uncached.update(uncachedConfig, scene, moved);
        const Drawn a = drawAndRead(kept);
        const Drawn b = drawAndRead(uncached);
        ASSERT_EQ(a.color, b.color) << "the kept frame differs from the uncached one";
        for (size_t l = 0; l < a.visibility.size(); ++l) ASSERT_EQ(a.visibility[l], b.visibility[l]) << "light " << l;
        EXPECT_TRUE(b.kept.empty()) << "keep_unchanged false kept " << b.kept.front();
        if (frameIndex > 0 && change == Change::None) {
            EXPECT_TRUE(a.ran.empty()) << "a still frame ran " << a.ran.front();
        }
        if (change == Change::Light) {
            EXPECT_TRUE(anyNamedFrom(a.ran, "light0.")) << "the moved light's passes were kept";
            EXPECT_TRUE(anyNamedFrom(a.kept, "light1.hard.shadow_map")) << "the other light's map was not kept";
        }
        if (change == Change::Camera) {
            EXPECT_TRUE(anyNamedFrom(a.ran, "gbuffer"));
            if (c.culling == config::CullingMode::None) {
                EXPECT_TRUE(anyNamedFrom(a.kept, "light1.hard.shadow_map")) << "a camera move redrew a light's map";
            } else {
                EXPECT_TRUE(anyNamedFrom(a.ran, "light1.hard.shadow_map")) << "culled for the old camera, kept";
            }
        }
        ++frameIndex;
    }
}

INSTANTIATE_TEST_SUITE_P(
    EveryTechniqueAndLightType, KeepUnchanged,
    ::testing::ValuesIn([] {
        std::vector<KeepCase> cases;
        const test::LightCase lights[] = {{"spot", scene::LightType::Spot},
                                          {"point", scene::LightType::Point},
                                          {"rect", scene::LightType::Rect},
                                          {"disk", scene::LightType::Disk},
                                          {"directional", scene::LightType::Directional}};
        for (const char* technique : {"hard", "pcss", "vsm", "vssm", "backprojection", "deep"})
            for (const test::LightCase& light : lights) cases.push_back({technique, light});
        // Casters culled for what the camera sees, and maps fitted to it.
        cases.push_back({"hard", lights[0], config::CullingMode::ReceiverMask});
        cases.push_back({"pcss", lights[1], config::CullingMode::LightOcclusion});
        cases.push_back({"vsm", lights[4], config::CullingMode::ReceiverMask, true});
        cases.push_back({"hard", lights[4], config::CullingMode::LightOcclusion, true});
        return cases;
    }()),
    [](const auto& info) {
        std::string name = std::string(info.param.technique) + "_" + info.param.light.name;
        if (info.param.culling != config::CullingMode::None) {
            name += std::string("_") + config::cullingModeName(info.param.culling);
            std::replace(name.begin(), name.end(), '-', '_');
        }
        return info.param.focus ? name + "_focus" : name;
    });

// FrameChanges on its own: which moves change which state.
TEST(FrameChanges, MovesChangeOnlyTheStatesThatSeeThem)
{
    scene::Scene scene;
    scene.meshes.emplace_back();
    scene.meshes[0].bounds.extend(glm::vec3(-0.5f));
    scene.meshes[0].bounds.extend(glm::vec3(0.5f));
    const uint32_t near = scene.graph.addNode("near", scene::kNoParent, glm::mat4(1.0f));
    const uint32_t far = scene.graph.addNode("far", scene::kNoParent, glm::translate(glm::mat4(1.0f), {0, 0, -40}));
    scene.addInstance(0, near);
    scene.addInstance(0, far);
    scene.graph.update();
    scene.updateTransforms();
    for (uint32_t i = 0; i < 2; ++i) scene.instances[i].worldBounds = scene.meshes[0].bounds.transformed(scene.graph.world(scene.instances[i].node));

    // A camera and a light that both look at the origin from +z; the far box is behind both.
    const glm::mat4 view = glm::lookAt(glm::vec3(0, 0, 5), glm::vec3(0), glm::vec3(0, 1, 0));
    const glm::mat4 viewProj = glm::perspective(glm::radians(30.0f), 1.0f, 0.1f, 20.0f) * view;
    scene::Light light;
    std::vector<scene::Light> lights{light};
    const std::vector<std::byte> table(64, std::byte{1});
    frame::FrameChanges changes(scene);
    frame::FrameInputs in;
    in.cameraViewProj = viewProj;
    in.lights = lights;
    in.sceneBounds = scene.bounds();
    in.lightTable = table;
    changes.update(in, scene);
    render::CasterView drawnView;
    drawnView.viewProj = viewProj;
    changes.viewsDrawn({&drawnView, 1});
    const uint64_t camera = changes.camera(), lightVersion = changes.light(0), tableVersion = changes.lightTable();

    changes.update(in, scene);
    EXPECT_EQ(changes.camera(), camera);
    EXPECT_EQ(changes.light(0), lightVersion);
    EXPECT_EQ(changes.lightTable(), tableVersion);

    // The far box moves behind the view, the scene's bounds unchanged: nothing changes.
    const scene::Aabb bounds = scene.bounds();
    scene.graph.setLocal(far, glm::translate(glm::mat4(1.0f), {0.5f, 0, -40}));
    std::vector<uint32_t> moved = scene.updateTransforms();
    in.movedInstances = moved;
    in.sceneBounds = bounds;  // as if another instance held the bounds
    changes.update(in, scene);
    EXPECT_EQ(changes.camera(), camera);
    EXPECT_EQ(changes.light(0), lightVersion);

    // The near box moves inside both views: both change.
    scene.graph.setLocal(near, glm::translate(glm::mat4(1.0f), {0.2f, 0, 0}));
    moved = scene.updateTransforms();
    in.movedInstances = moved;
    changes.update(in, scene);
    EXPECT_GT(changes.camera(), camera);
    EXPECT_GT(changes.light(0), lightVersion);

    // The camera moves: the light keeps its version unless its casters follow the camera.
    const uint64_t lightBefore = changes.light(0);
    in.movedInstances = {};
    in.cameraViewProj = glm::translate(viewProj, {0.1f, 0, 0});
    changes.update(in, scene);
    EXPECT_EQ(changes.light(0), lightBefore);
    in.cameraViewProj = viewProj;
    in.castersFollowCamera = true;
    changes.update(in, scene);
    EXPECT_GT(changes.light(0), lightBefore);

    // The light table: any byte.
    std::vector<std::byte> edited = table;
    edited[10] = std::byte{2};
    in.lightTable = edited;
    changes.update(in, scene);
    EXPECT_GT(changes.lightTable(), tableVersion);

    const scene::Frustum frustum = scene::frustumFromViewProj(viewProj);
    EXPECT_FALSE(frame::boxMayBeInView(scene::Aabb{}, frustum)) << "an empty box";
    EXPECT_TRUE(frame::boxMayBeInView(scene.instances[0].worldBounds, frustum));
    EXPECT_FALSE(frame::boxMayBeInView(scene.instances[1].worldBounds, frustum)) << "behind the camera";
}
