#define GLM_ENABLE_EXPERIMENTAL  // glm/gtx: eulerAngleXYZ, the convention rotation_deg shares with node tracks
// A scene made of parts ("scene": {"parts": [...]}): glTF files and generators, each
// placed by a translation, rotation and scale, combined into one scene graph with one
// root node per part. No Vulkan device: buildScene is CPU-side.
#include "ScratchFolder.h"
#include "TestPaths.h"  // support/: the build tree's paths

#include "penumbra/config/Config.h"
#include "penumbra/core/Error.h"
#include "penumbra/scene/Generators.h"

#include <fmt/format.h>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtx/euler_angles.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <set>
#include <unistd.h>

using namespace penumbra;
using nlohmann::json;
namespace fs = std::filesystem;

// Named: the unit tests are built as one unity file, where other tests' helpers share names.
namespace scene_parts_test {

std::string gltf(const char* name) { return (test::testDataDir() / "gltf" / name).string(); }

json withScene(const json& scene)
{
    return {{"scene", scene},
            {"camera", {{"position", {0, 5, 10}}, {"target", {0, 0, 0}}}},
            {"lights", json::array({{{"type", "directional"}, {"direction", {0, -1, 0}}}})}};
}

config::RenderConfig parse(const json& scene) { return config::parseConfig(withScene(scene), "parts.json"); }

scene::Scene build(const json& scene)
{
    config::RenderConfig c = parse(scene);
    return config::buildScene(c);
}

// A small box-grid keeps each build cheap.
const json kSmallGrid = {{"generator", "box-grid"}, {"params", {{"columns", 3}, {"rows", 2}, {"sphere_segments", 8}}}};

// The error a config's scene gets, from parsing or else from building it.
std::string errorOf(const json& scene)
{
    try {
        config::RenderConfig c = parse(scene);
        config::buildScene(c);
    } catch (const ConfigError& e) {
        return e.what();
    }
    ADD_FAILURE() << "scene was accepted: " << scene.dump();
    return {};
}

// Boxes compared to `tolerance` times the larger of their sizes (float world positions).
void expectBox(const scene::Aabb& got, const scene::Aabb& want, float tolerance = 1e-6f)
{
    const float size = std::max({glm::length(want.extent()), glm::length(want.max), glm::length(want.min), 1.0f});
    EXPECT_LE(glm::length(got.min - want.min), tolerance * size) << "min " << got.min.x << " " << got.min.y << " " << got.min.z;
    EXPECT_LE(glm::length(got.max - want.max), tolerance * size) << "max " << got.max.x << " " << got.max.y << " " << got.max.z;
}

// Parts add up: the combined scene draws each part's triangles and instances, with each
// part's materials and textures, and one root node per part above the part's own nodes.
TEST(SceneParts, PartsCombineIntoOneScene)
{
    const json ground = kSmallGrid;
    const json model = {{"gltf", gltf("hierarchy.gltf")}};
    const json textured = {{"gltf", gltf("textured.gltf")}, {"translation", {0, 2, 0}}};
    const scene::Scene a = build(ground), b = build(model), c = build(textured);
    const scene::Scene all = build({{"parts", {ground, model, textured}}});
    EXPECT_EQ(all.triangleCount(), a.triangleCount() + b.triangleCount() + c.triangleCount());
    EXPECT_EQ(all.instances.size(), a.instances.size() + b.instances.size() + c.instances.size());
    EXPECT_EQ(all.meshes.size(), a.meshes.size() + b.meshes.size() + c.meshes.size());
    EXPECT_EQ(all.materialsUsed(), a.materialsUsed() + b.materialsUsed() + c.materialsUsed());
    EXPECT_EQ(all.textures.size(), c.textures.size());
    EXPECT_GT(c.textures.size(), 0u);
    // Every material of the textured part still names its texture.
    for (const scene::Mesh& mesh : all.meshes) {
        const int32_t texture = all.materials.at(mesh.material).baseColorTexture;
        EXPECT_TRUE(texture == scene::kNoTexture || size_t(texture) < all.textures.size());
    }
    size_t roots = 0;
    for (uint32_t n = 0; n < all.graph.size(); ++n) roots += all.graph.node(n).parent == scene::kNoParent;
    EXPECT_EQ(roots, 3u);
    EXPECT_EQ(all.graph.node(0).name, "part0");

    const config::RenderConfig config = parse({{"parts", {ground, model, textured}}});
    const std::vector<config::PartSummary> parts = config::summarizeParts(config.scene, all);
    ASSERT_EQ(parts.size(), 3u);
    EXPECT_EQ(parts[1].triangles, b.triangleCount());
    EXPECT_EQ(parts[2].instances, c.instances.size());
    expectBox(parts[0].bounds, a.bounds());
    expectBox(parts[2].bounds, c.bounds());  // translated alone as together
}

// A part's translation, rotation and scale move its instances' world bounds: x' = T R S x,
// compared to 1e-6 of the scene's size.
TEST(SceneParts, ATransformMovesThePartsWorldBounds)
{
    const json model = {{"gltf", gltf("hierarchy.gltf")}};
    const scene::Aabb rest = build(model).bounds();
    ASSERT_FALSE(rest.empty());

    json moved = model;
    moved["translation"] = {10.5, -2, 1e3};
    const glm::vec3 t(10.5f, -2.0f, 1e3f);
    expectBox(build(moved).bounds(), {rest.min + t, rest.max + t});

    json scaled = model;
    scaled["scale"] = {2, 0.5, 3};
    const glm::vec3 s(2.0f, 0.5f, 3.0f);
    expectBox(build(scaled).bounds(), {rest.min * s, rest.max * s});

    // Euler degrees as a node track's rotation_deg (glm::eulerAngleXYZ), and the same
    // rotation as a quaternion: the rest box's corners turned.
    json euler = model;
    euler["rotation_deg"] = {30, 45, 60};
    const glm::mat4 r = glm::eulerAngleXYZ(glm::radians(30.0f), glm::radians(45.0f), glm::radians(60.0f));
    const scene::Scene turned = build(euler);
    // Each instance's box is its mesh's box under the whole transform, as Scene keeps it.
    scene::Aabb got;
    for (const scene::Instance& instance : turned.instances) got.extend(instance.worldBounds);
    const scene::Scene plain = build(model);
    scene::Aabb want;
    for (const scene::Instance& instance : plain.instances) {
        want.extend(plain.meshes[instance.mesh].bounds.transformed(r * plain.instanceTransform(instance)));
    }
    expectBox(got, want, 1e-5f);

    json quaternion = model;
    const glm::quat q = glm::quat_cast(r);
    quaternion["rotation"] = {q.x, q.y, q.z, q.w};
    expectBox(build(quaternion).bounds(), got, 1e-5f);

    // All three at once: T · R · S.
    json all = model;
    all["translation"] = {1, 2, 3};
    all["rotation_deg"] = {0, 90, 0};
    all["scale"] = 2;
    const glm::mat4 m = glm::translate(glm::mat4(1.0f), glm::vec3(1, 2, 3)) * glm::eulerAngleY(glm::radians(90.0f)) *
                        glm::scale(glm::mat4(1.0f), glm::vec3(2.0f));
    scene::Aabb trs;
    for (const scene::Instance& instance : plain.instances) {
        trs.extend(plain.meshes[instance.mesh].bounds.transformed(m * plain.instanceTransform(instance)));
    }
    expectBox(build(all).bounds(), trs, 1e-5f);
}

// The single-part forms mean what they meant: one part, its scale about the origin (as
// scaleScene does), written back without "parts".
TEST(SceneParts, TheSinglePartFormsAreOnePart)
{
    const config::RenderConfig generated = parse({{"generator", "fence"}, {"scale", 2}});
    ASSERT_EQ(generated.scene.parts.size(), 1u);
    EXPECT_FALSE(generated.scene.listed);
    EXPECT_EQ(generated.scene.parts[0].pointer, "/scene");
    EXPECT_EQ(generated.scene.parts[0].transform.scale, glm::dvec3(2.0));
    EXPECT_TRUE(generated.scene.parts[0].transform.rotationDeg == std::nullopt);
    scene::Scene expected = scene::generateScene("fence", {});
    scene::scaleScene(expected, 2.0f);
    config::RenderConfig c = generated;
    const scene::Scene got = config::buildScene(c);
    ASSERT_EQ(got.instances.size(), expected.instances.size());
    for (size_t i = 0; i < got.instances.size(); ++i) {
        EXPECT_EQ(got.instances[i].worldBounds.min, expected.instances[i].worldBounds.min) << i;
        EXPECT_EQ(got.instances[i].worldBounds.max, expected.instances[i].worldBounds.max) << i;
    }
    const json written = config::configJson(generated, "x.json")["scene"];
    EXPECT_EQ(written["generator"], "fence");
    EXPECT_EQ(written["scale"], 2.0);
    EXPECT_FALSE(written.contains("parts"));
    // One part listed stays listed.
    EXPECT_TRUE(config::configJson(parse({{"parts", {kSmallGrid}}}), "x.json")["scene"].contains("parts"));
}

// Every bad field is named by its JSON path, with what is expected.
TEST(SceneParts, EveryBadFieldIsNamed)
{
    const json model = {{"gltf", gltf("quad.glb")}};
    const auto part = [&](const char* key, const json& value) {
        json p = model;
        p[key] = value;
        return json{{"parts", {kSmallGrid, p}}};
    };
    json tooMany = {{"parts", json::array()}};
    for (int i = 0; i < 65; ++i) tooMany["parts"].push_back(kSmallGrid);
    json bothRotations = part("rotation_deg", {0, 90, 0});
    bothRotations["parts"][1]["rotation"] = {0, 0, 0, 1};
    json duplicate = part("name", "ground");
    duplicate["parts"][0]["name"] = "ground";
    json badParams = kSmallGrid;
    badParams["params"]["rows"] = 0;
    const std::vector<std::pair<json, std::string>> cases = {
        {{{"parts", "a.glb"}}, "parts.json: /scene/parts: must be an array of 1 to 64 parts"},
        {{{"parts", json::array()}}, "/scene/parts: must be an array of 1 to 64 parts (objects with \"gltf\" or \"generator\"), got 0 parts"},
        {tooMany, "/scene/parts: must be an array of 1 to 64 parts (objects with \"gltf\" or \"generator\"), got 65 parts"},
        {{{"parts", {kSmallGrid}}, {"generator", "city"}}, "/scene/generator: give either \"parts\" or one part's keys"},
        {{{"parts", {3}}}, "/scene/parts/0: must be an object, got number"},
        {part("translation", {1, 2}), "/scene/parts/1/translation: must be [x, y, z], got [1,2]"},
        {part("translation", {1, 2, "3"}), "/scene/parts/1/translation/2: must be a number, got \"3\""},
        {part("translation", {1, 2e9, 3}), "/scene/parts/1/translation/1: must be in [-1000000000, 1000000000], got 2000000000"},
        {part("translation", {1, std::nan(""), 3}), "/scene/parts/1/translation/1: must be in [-1000000000, 1000000000]"},
        {part("scale", 0), "/scene/parts/1/scale: must be in (0, 1000000000], got 0"},
        {part("scale", -2), "/scene/parts/1/scale: must be in (0, 1000000000], got -2"},
        {part("scale", std::numeric_limits<double>::infinity()), "/scene/parts/1/scale: must be in (0, 1000000000]"},
        {part("scale", {1, 0, 1}), "/scene/parts/1/scale/1: must be in (0, 1000000000], got 0"},
        {part("scale", {1, 1}), "/scene/parts/1/scale: must be a number or [sx, sy, sz], got [1,1]"},
        {part("scale", "big"), "/scene/parts/1/scale: must be a number in (0, 1000000000] or [sx, sy, sz] of such, got \"big\""},
        {part("rotation_deg", {0, 400, 0}), "/scene/parts/1/rotation_deg/1: must be in [-360, 360], got 400"},
        {part("rotation_deg", {0, 90}), "/scene/parts/1/rotation_deg: must be [x, y, z] in degrees"},
        {part("rotation", {0, 0, 0, 2}), "/scene/parts/1/rotation/3: must be in [-1.01, 1.01], got 2"},
        {part("rotation", {0, 1, 0, 1}), "/scene/parts/1/rotation: must be a unit quaternion [x, y, z, w] (length 1 ± 0.01), "
                                         "got [0,1,0,1] of length 1.41421"},
        {part("rotation", {0, 0, 1}), "/scene/parts/1/rotation: must be a unit quaternion [x, y, z, w] (glTF's order), got [0,0,1]"},
        {bothRotations, "/scene/parts/1/rotation: give either \"rotation_deg\" (Euler angles) or \"rotation\" (a quaternion), not both"},
        {part("scael", 2), "/scene/parts/1/scael: unknown key for a glTF part; did you mean \"scale\"?"},
        {part("gltf", "nowhere.glb"), "/scene/parts/1/gltf: file not found: "},
        {part("gltf", 3), "/scene/parts/1/gltf: must be a file path, got 3"},
        {part("generator", "city"), "/scene/parts/1: give either \"gltf\" or \"generator\", not both"},
        {part("name", ""), "/scene/parts/1/name: must be a non-empty string, got \"\""},
        {duplicate, "/scene/parts/1/name: duplicate part name \"ground\""},
        {part("animation", "dance"), "parts.json: /scene/parts/1/animation: "},
        {part("allowed_roots", {"nowhere"}), "/scene/parts/1/allowed_roots/0: folder not found: "},
        {{{"parts", {kSmallGrid, {{"generator", "box-grid"}, {"animation", "wave"}}}}},
         "/scene/parts/1/animation: unknown key for a generator part"},
        {{{"parts", {model, badParams}}},
         "parts.json: /scene/parts/1/params/rows: must be a whole number in [1, 1024] (generator box-grid, parameter rows: "},
    };
    for (const auto& [scene, expected] : cases) {
        const std::string message = errorOf(scene);
        EXPECT_NE(message.find(expected), std::string::npos) << "expected: " << expected << "\ngot: " << message;
    }
}

// "lights": "scene" takes the lights of every glTF part, placed by its transform: the
// position transformed, the direction turned, a spot or point light's intensity times
// s² (s the part's scale); a name an earlier part took becomes light<i>.
TEST(SceneParts, LightsComeFromEveryGltfPartPlacedByItsTransform)
{
    json doc = withScene({{"parts",
                           {{{"gltf", gltf("hierarchy.gltf")}},
                            {{"gltf", gltf("hierarchy.gltf")}, {"translation", {10, 0, 0}}, {"rotation_deg", {0, 0, 0}}, {"scale", 2}}}}});
    doc["lights"] = "scene";
    config::RenderConfig c = config::parseConfig(doc, "parts.json");
    config::buildScene(c);
    ASSERT_EQ(c.lights.size(), 6u);
    for (size_t i = 0; i < 3; ++i) {
        SCOPED_TRACE(i);
        const scene::Light &a = c.lights[i].light, &b = c.lights[i + 3].light;
        EXPECT_EQ(c.lights[i + 3].name, fmt::format("light{}", i + 3));  // its file's name is taken
        EXPECT_EQ(a.type, b.type);
        if (a.type == scene::LightType::Directional) {
            EXPECT_EQ(a.intensity, b.intensity);
        } else {
            EXPECT_NEAR(glm::length(b.position - (2.0f * a.position + glm::vec3(10, 0, 0))), 0.0f, 1e-5f);
            EXPECT_FLOAT_EQ(b.intensity, 4.0f * a.intensity);
        }
        EXPECT_NEAR(glm::length(a.direction - b.direction), 0.0f, 1e-6f);
    }
    std::set<std::string> fileNames;
    for (size_t i = 0; i < 3; ++i) fileNames.insert(c.lights[i].name);
    EXPECT_EQ(fileNames, (std::set<std::string>{"sun", "lamp", "bulb"}));
    // A quarter turn about y turns a spot's axis with the part.
    doc["scene"]["parts"][1]["rotation_deg"] = {0, 90, 0};
    doc["scene"]["parts"][1]["scale"] = 1;
    c = config::parseConfig(doc, "parts.json");
    config::buildScene(c);
    const glm::vec3 turned = glm::vec3(glm::eulerAngleY(glm::radians(90.0f)) * glm::vec4(c.lights[1].light.direction, 0.0f));
    EXPECT_NEAR(glm::length(c.lights[4].light.direction - turned), 0.0f, 1e-6f);
    // A scene of generators only has no file lights to take.
    doc["scene"] = {{"parts", {kSmallGrid}}};
    EXPECT_THROW(config::parseConfig(doc, "parts.json"), ConfigError);
}

// Each glTF part may play one of its own file's animations, named or indexed among that
// file's; the parts move independently, each under its own transform; a node track on a
// part's name moves the whole part.
TEST(SceneParts, EachPartPlaysItsOwnAnimation)
{
    const json still = {{"gltf", gltf("animated.gltf")}, {"name", "still"}};
    const json waving = {{"gltf", gltf("animated.gltf")}, {"name", "waving"}, {"animation", "wave"}, {"translation", {0, 0, -20}}};
    const json spinning = {{"gltf", gltf("animated.gltf")}, {"name", "spinning"}, {"animation", 1}, {"translation", {20, 0, 0}}};
    json doc = withScene({{"parts", {still, waving, spinning}}});
    config::PreparedRun run = config::prepareRun(config::parseConfig(doc, "parts.json"), {});
    // The file has clips wave and spin: the scene holds both for each part.
    ASSERT_EQ(run.scene.animations.size(), 6u);
    EXPECT_EQ(config::playedClips(run.rest, run.scene), (std::vector<size_t>{2, 5}));
    EXPECT_FLOAT_EQ(config::animationDuration(run.rest, run.scene), 2.0f);
    ASSERT_EQ(run.scene.instances.size(), 3u);
    const glm::vec3 rest0 = run.scene.instances[0].worldBounds.center();
    run.poseAt(1.0f);
    // wave at 1 s: translated (2, 1, 0) from the part's place.
    EXPECT_NEAR(glm::length(run.scene.instances[1].worldBounds.center() - glm::vec3(2, 1, -20)), 0.0f, 1e-5f);
    EXPECT_NEAR(glm::length(run.scene.instances[2].worldBounds.center() - glm::vec3(20, 0, 0)), 0.0f, 1e-5f);
    EXPECT_EQ(run.scene.instances[0].worldBounds.center(), rest0);

    doc["animation"] = {{"tracks", {{{"target", "node:still/translation"}, {"keys", {{{"t", 0}, {"value", {0, 5, 0}}}}}}}}};
    run = config::prepareRun(config::parseConfig(doc, "parts.json"), {});
    run.poseAt(0.0f);
    EXPECT_NEAR(glm::length(run.scene.instances[0].worldBounds.center() - glm::vec3(0, 5, 0)), 0.0f, 1e-5f);

    // An index counts among the part's own file's animations.
    doc["scene"]["parts"][2]["animation"] = 2;
    try {
        config::prepareRun(config::parseConfig(doc, "parts.json"), {});
        FAIL() << "a third animation of a file with two was accepted";
    } catch (const ConfigError& e) {
        const std::string what = e.what();
        EXPECT_NE(what.find("parts.json: /scene/parts/2/animation: "), std::string::npos) << what;
        EXPECT_NE(what.find("its animations: \"wave\", \"spin\" (or their index)"), std::string::npos) << what;
    }
}

// A part's file reads only under its own folder and its allowed roots, the part's own
// and the command line's (RunOptions::allowedRoots, --allow-root), as a single glTF does.
TEST(SceneParts, EveryPartsFileKeepsToItsAllowedRoots)
{
    const test::ScratchFolder scratch("scene_parts");
    const fs::path& dir = scratch.path;
    fs::create_directories(dir / "model");
    fs::create_directories(dir / "shared");
    fs::copy_file(test::testDataDir() / "gltf" / "quad.bin", dir / "shared" / "quad.bin", fs::copy_options::overwrite_existing);
    std::ifstream in(test::testDataDir() / "gltf" / "quad_external.gltf");
    json model = json::parse(in);
    model["buffers"][0]["uri"] = "../shared/quad.bin";
    std::ofstream(dir / "model" / "m.gltf") << model.dump();
    json doc = withScene({{"parts", {{{"gltf", gltf("quad.glb")}}, {{"gltf", (dir / "model" / "m.gltf").string()}}}}});
    std::string message;
    try {
        config::prepareRun(config::parseConfig(doc, dir / "c.json"), {});
    } catch (const ConfigError& e) {
        message = e.what();
    }
    EXPECT_NE(message.find("/scene/parts/1: "), std::string::npos) << message;
    EXPECT_NE(message.find("outside the model's folder"), std::string::npos) << message;
    config::RunOptions options;
    options.allowedRoots = {dir / "shared"};
    EXPECT_EQ(config::prepareRun(config::parseConfig(doc, dir / "c.json"), options).scene.instances.size(), 2u);
    doc["scene"]["parts"][1]["allowed_roots"] = {"shared"};
    EXPECT_EQ(config::prepareRun(config::parseConfig(doc, dir / "c.json"), {}).scene.instances.size(), 2u);
}

// The materials count says what the meshes use: a file with two materials has two,
// though the scene also holds the default (index 0) for primitives without one.
TEST(SceneParts, MaterialsUsedCountsWhatMeshesUse)
{
    const scene::Scene s = build({{"gltf", gltf("hierarchy.gltf")}});
    EXPECT_EQ(s.materials.size(), 4u);  // the scene's default, the part's default and its file's two
    EXPECT_EQ(s.materialsUsed(), 2u);
}

} // namespace scene_parts_test
