// glTF export: what tinygltf reads back is the scene that was written (counts,
// hierarchy, transformed vertices, materials, textures), and a failed write leaves no
// file behind and the existing one intact.
#include "ScratchFolder.h"

#include "penumbra/core/Error.h"
#include "penumbra/scene/Generators.h"
#include "penumbra/scene/GltfLoader.h"
#include "penumbra/scene/GltfWriter.h"

#include <fmt/format.h>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <tiny_gltf.h>

#include <unistd.h>

#include <cstring>
#include <fstream>
#include <sstream>

using namespace penumbra;
using namespace penumbra::scene;
namespace fs = std::filesystem;

namespace {

class GltfWriter : public test::ScratchFolderTest {
protected:
    std::vector<std::string> filesInDir() const
    {
        std::vector<std::string> names;
        for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
        std::sort(names.begin(), names.end());
        return names;
    }
};

tinygltf::Model load(const fs::path& path)
{
    tinygltf::TinyGLTF loader;
    tinygltf::Model model;
    std::string err, warn;
    const bool ok = path.extension() == ".glb" ? loader.LoadBinaryFromFile(&model, &err, &warn, path.string())
                                               : loader.LoadASCIIFromFile(&model, &err, &warn, path.string());
    EXPECT_TRUE(ok) << err;
    EXPECT_TRUE(warn.empty()) << warn;
    return model;
}

glm::mat4 localOf(const tinygltf::Node& node)
{
    glm::mat4 m(1.0f);
    if (node.matrix.size() == 16) {
        for (int i = 0; i < 16; ++i) m[i / 4][i % 4] = float(node.matrix[size_t(i)]);
        return m;
    }
    if (node.translation.size() == 3) m = glm::translate(m, glm::vec3(node.translation[0], node.translation[1], node.translation[2]));
    if (node.rotation.size() == 4) {
        m *= glm::mat4_cast(glm::quat(float(node.rotation[3]), float(node.rotation[0]), float(node.rotation[1]), float(node.rotation[2])));
    }
    if (node.scale.size() == 3) m = glm::scale(m, glm::vec3(node.scale[0], node.scale[1], node.scale[2]));
    return m;
}

// Parent of every node, from the children lists.
std::vector<int> parentsOf(const tinygltf::Model& model)
{
    std::vector<int> parents(model.nodes.size(), -1);
    for (size_t n = 0; n < model.nodes.size(); ++n) {
        for (int child : model.nodes[n].children) parents.at(size_t(child)) = int(n);
    }
    return parents;
}

glm::mat4 worldOf(const tinygltf::Model& model, const std::vector<int>& parents, int node)
{
    glm::mat4 m(1.0f);
    for (int n = node; n != -1; n = parents[size_t(n)]) m = localOf(model.nodes[size_t(n)]) * m;
    return m;
}

glm::vec3 vertexPosition(const tinygltf::Model& model, int meshIndex, size_t vertex)
{
    const tinygltf::Accessor& accessor = model.accessors.at(size_t(model.meshes.at(size_t(meshIndex)).primitives.at(0).attributes.at("POSITION")));
    const tinygltf::BufferView& view = model.bufferViews.at(size_t(accessor.bufferView));
    const size_t stride = size_t(accessor.ByteStride(view));
    glm::vec3 p;
    std::memcpy(&p, model.buffers.at(size_t(view.buffer)).data.data() + view.byteOffset + accessor.byteOffset + vertex * stride, sizeof(p));
    return p;
}

// Three levels, a mesh shared by two nodes, a node with two instances, every alpha
// mode, a texture.
Scene handMadeScene()
{
    Scene s;
    s.textures.push_back({"checker", 2, 2, {255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 10, 20, 30, 128}});
    Material mask{"leaf", {0.2f, 0.7f, 0.3f, 1.0f}, 0, AlphaMode::Mask, 0.35f, true};
    Material glass{"glass", {0.6f, 0.8f, 0.9f, 0.25f}, kNoTexture, AlphaMode::Blend, 0.5f, false};
    s.materials.push_back(mask);
    s.materials.push_back(glass);
    Mesh box = makeBox("box");
    box.material = 1;
    Mesh ball = makeSphere("ball", 8);
    ball.material = 2;
    for (Mesh* m : {&box, &ball}) {
        m->computeBounds();
        s.meshes.push_back(*m);
    }
    const uint32_t root = s.graph.addNode("root", kNoParent, glm::translate(glm::mat4(1.0f), {1, 2, 3}));
    const uint32_t turned = s.graph.addNode("turned", int32_t(root), glm::rotate(glm::mat4(1.0f), 0.7f, glm::normalize(glm::vec3(1, 2, 0.5f))));
    const uint32_t leaf = s.graph.addNode("leaf", int32_t(turned), glm::scale(glm::translate(glm::mat4(1.0f), {0, 5, 0}), {2, 0.5f, 1}));
    const uint32_t other = s.graph.addNode("other root", kNoParent, glm::mat4(1.0f));
    s.addInstance(0, leaf);
    s.addInstance(1, leaf);  // two instances under one node
    s.addInstance(0, other);  // the box shared by a second node
    s.addInstance(1, turned);
    return s;
}

void expectRoundTrip(const Scene& scene, const fs::path& path)
{
    SCOPED_TRACE(path.filename().string());
    writeGltf(scene, path);
    const tinygltf::Model model = load(path);

    ASSERT_EQ(model.meshes.size(), scene.meshes.size());
    ASSERT_EQ(model.materials.size(), scene.materials.size());
    ASSERT_EQ(model.textures.size(), scene.textures.size());
    size_t meshNodes = 0;
    for (const tinygltf::Node& n : model.nodes) meshNodes += n.mesh >= 0;
    EXPECT_EQ(meshNodes, scene.instances.size());
    ASSERT_GE(model.nodes.size(), scene.graph.size());

    // Hierarchy and names: glTF node i is scene node i.
    const std::vector<int> parents = parentsOf(model);
    for (uint32_t n = 0; n < scene.graph.size(); ++n) {
        EXPECT_EQ(parents[n], scene.graph.node(n).parent) << n;
        EXPECT_EQ(model.nodes[n].name, scene.graph.node(n).name);
    }
    ASSERT_EQ(model.scenes.size(), 1u);
    for (int root : model.scenes[0].nodes) EXPECT_EQ(parents[size_t(root)], -1);

    // Every instance: same mesh, same world transform of a vertex.
    for (const Instance& inst : scene.instances) {
        int found = -1;
        for (size_t n = 0; n < model.nodes.size(); ++n) {
            const bool here = n == inst.node || (n >= scene.graph.size() && parents[n] == int(inst.node));
            if (here && model.nodes[n].mesh == int(inst.mesh)) found = int(n);
        }
        ASSERT_GE(found, 0) << "mesh " << inst.mesh << " under node " << inst.node;
        const Mesh& mesh = scene.meshes[inst.mesh];
        const size_t vertex = mesh.vertices.size() / 2;
        const glm::vec3 expected = glm::vec3(scene.instanceTransform(inst) * glm::vec4(mesh.vertices[vertex].position, 1.0f));
        const glm::vec3 read = glm::vec3(worldOf(model, parents, found) * glm::vec4(vertexPosition(model, int(inst.mesh), vertex), 1.0f));
        const float tolerance = 1e-5f * std::max(1.0f, glm::length(expected));
        EXPECT_NEAR(read.x, expected.x, tolerance);
        EXPECT_NEAR(read.y, expected.y, tolerance);
        EXPECT_NEAR(read.z, expected.z, tolerance);
    }

    // Geometry: u32 indices, POSITION bounds, vertex and index counts.
    for (size_t m = 0; m < scene.meshes.size(); ++m) {
        const tinygltf::Primitive& prim = model.meshes[m].primitives.at(0);
        EXPECT_EQ(prim.mode, TINYGLTF_MODE_TRIANGLES);
        EXPECT_EQ(prim.material, int(scene.meshes[m].material));
        const tinygltf::Accessor& indices = model.accessors.at(size_t(prim.indices));
        EXPECT_EQ(indices.componentType, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT);
        EXPECT_EQ(indices.count, scene.meshes[m].indices.size());
        const tinygltf::Accessor& position = model.accessors.at(size_t(prim.attributes.at("POSITION")));
        EXPECT_EQ(position.count, scene.meshes[m].vertices.size());
        ASSERT_EQ(position.minValues.size(), 3u);
        ASSERT_EQ(position.maxValues.size(), 3u);
        for (int a = 0; a < 3; ++a) {
            EXPECT_EQ(float(position.minValues[size_t(a)]), scene.meshes[m].bounds.min[a]);
            EXPECT_EQ(float(position.maxValues[size_t(a)]), scene.meshes[m].bounds.max[a]);
        }
        EXPECT_TRUE(prim.attributes.count("NORMAL") && prim.attributes.count("TEXCOORD_0"));
    }

    // Materials.
    for (size_t i = 0; i < scene.materials.size(); ++i) {
        const Material& want = scene.materials[i];
        const tinygltf::Material& got = model.materials[i];
        EXPECT_EQ(got.name, want.name);
        for (int c = 0; c < 4; ++c) EXPECT_EQ(float(got.pbrMetallicRoughness.baseColorFactor.at(size_t(c))), want.baseColor[c]);
        EXPECT_EQ(got.alphaMode, want.alphaMode == AlphaMode::Mask ? "MASK" : want.alphaMode == AlphaMode::Blend ? "BLEND" : "OPAQUE");
        EXPECT_EQ(float(got.alphaCutoff), want.alphaCutoff);
        EXPECT_EQ(got.doubleSided, want.doubleSided);
        EXPECT_EQ(got.pbrMetallicRoughness.baseColorTexture.index, want.baseColorTexture);
    }
    for (size_t t = 0; t < scene.textures.size(); ++t) {
        const tinygltf::Image& image = model.images.at(size_t(model.textures[t].source));
        EXPECT_EQ(image.width, int(scene.textures[t].width));
        EXPECT_EQ(image.height, int(scene.textures[t].height));
        EXPECT_EQ(image.image, scene.textures[t].rgba);
    }
}

std::string slurp(const fs::path& p)
{
    std::ifstream in(p, std::ios::binary);
    std::ostringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

// The buffer file a written .gltf references (its URI as written).
std::string bufferUri(const fs::path& gltf)
{
    return nlohmann::json::parse(slurp(gltf))["buffers"][0]["uri"].get<std::string>();
}

// `<stem>.<16 lowercase hex digits>.bin`: the writer's content-named buffer.
bool isContentNamedBuffer(const std::string& name, const std::string& stem)
{
    const std::string hex = name.substr(std::min(name.size(), stem.size() + 1), 16);
    return name.size() == stem.size() + 21 && name.rfind(stem + ".", 0) == 0 && name.ends_with(".bin") &&
           hex.find_first_not_of("0123456789abcdef") == std::string::npos;
}

} // namespace

TEST_F(GltfWriter, HandMadeSceneRoundTrips)
{
    const Scene scene = handMadeScene();
    expectRoundTrip(scene, dir / "hand.gltf");
    expectRoundTrip(scene, dir / "hand.glb");
    // Nothing but the outputs: no temporary files.
    const std::vector<std::string> files = filesInDir();
    ASSERT_EQ(files.size(), 3u);
    EXPECT_TRUE(isContentNamedBuffer(files[0], "hand")) << files[0];
    EXPECT_EQ(files[0], bufferUri(dir / "hand.gltf"));
    EXPECT_EQ(files[1], "hand.glb");
    EXPECT_EQ(files[2], "hand.gltf");
}

TEST_F(GltfWriter, GeneratedScenesRoundTrip)
{
    expectRoundTrip(generateScene("fence", {{"holes_x", "5"}, {"holes_y", "4"}, {"tilt_deg", "30"}}), dir / "fence.gltf");
    expectRoundTrip(generateScene("city", {{"blocks", "2"}}), dir / "city.glb");
    Scene hair = generateScene("hair", {{"strands", "40"}});
    expectRoundTrip(scaleScene(hair, 1e-3f), dir / "hair.glb");
}

TEST_F(GltfWriter, BinaryFileNameIsUriEncoded)
{
    expectRoundTrip(generatePenumbra({}), dir / "a b+c.gltf");
    const std::string uri = bufferUri(dir / "a b+c.gltf");
    EXPECT_EQ(uri.rfind("a%20b%2Bc.", 0), 0u) << uri;
    const std::vector<std::string> files = filesInDir();
    ASSERT_EQ(files.size(), 2u);
    EXPECT_TRUE(isContentNamedBuffer(files[0], "a b+c")) << files[0];
    EXPECT_EQ("a%20b%2Bc." + files[0].substr(std::string("a b+c.").size()), uri);
}

TEST_F(GltfWriter, RejectsBadPathsAndLeavesNoFile)
{
    const Scene scene = generatePenumbra({});
    auto message = [&](const fs::path& path) {
        try {
            writeGltf(scene, path);
        } catch (const Error& e) {
            return std::string(e.what());
        }
        return std::string("(no error)");
    };
    EXPECT_NE(message(dir / "scene.obj").find("unknown glTF extension '.obj', expected .gltf or .glb"), std::string::npos);
    EXPECT_NE(message(dir / "missing" / "scene.gltf").find("does not exist"), std::string::npos);
    EXPECT_NE(message("/proc/penumbra-scene.glb").find("/proc/penumbra-scene.glb"), std::string::npos);
    EXPECT_TRUE(filesInDir().empty());
}

TEST_F(GltfWriter, FailedWriteKeepsTheExistingFiles)
{
    std::ofstream(dir / "scene.gltf") << "keep me";
    std::ofstream(dir / "scene.bin") << "and me";
    Scene broken = generatePenumbra({});
    broken.meshes[1].indices.push_back(999);
    broken.meshes[1].indices.push_back(0);
    broken.meshes[1].indices.push_back(1);
    try {
        writeGltf(broken, dir / "scene.gltf");
        FAIL() << "expected Error";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("mesh 'occluder': index 999 past its 24 vertices"), std::string::npos) << e.what();
    }
    EXPECT_EQ(slurp(dir / "scene.gltf"), "keep me");
    EXPECT_EQ(slurp(dir / "scene.bin"), "and me");
    EXPECT_EQ(filesInDir(), (std::vector<std::string>{"scene.bin", "scene.gltf"}));
    // A good write then replaces both: the .gltf, and its buffer under a new name (the
    // plain scene.bin of earlier versions goes once the new .gltf is in place).
    writeGltf(generatePenumbra({}), dir / "scene.gltf");
    EXPECT_NE(slurp(dir / "scene.gltf"), "keep me");
    EXPECT_EQ(filesInDir(), (std::vector<std::string>{bufferUri(dir / "scene.gltf"), "scene.gltf"}));
}

// Multi-file output all or nothing (issue 20): a kill between the renames of a rewrite
// must not leave a new scene.bin beside the old scene.gltf, which would fail to load.
// Each buffer is named by its content, so writing the new one never touches the one the
// old .gltf reads, and the .gltf's rename switches pairs at once.
TEST_F(GltfWriter, RewriteSwitchesTheGltfAndItsBufferAtOnce)
{
    const Scene first = generatePenumbra({});
    const Scene second = generateScene("fence", {{"holes_x", "3"}, {"holes_y", "2"}});
    writeGltf(first, dir / "scene.gltf");
    const std::string firstBin = bufferUri(dir / "scene.gltf");
    // Killed after the new buffer's rename, before the .gltf's: the old .gltf still
    // loads the first scene from its own buffer.
    const fs::path staged = dir / "staged";
    fs::create_directories(staged);
    writeGltf(second, staged / "scene.gltf");
    const std::string secondBin = bufferUri(staged / "scene.gltf");
    ASSERT_NE(secondBin, firstBin);
    fs::copy_file(staged / secondBin, dir / secondBin);
    fs::remove_all(staged);
    GltfLoadReport report;
    EXPECT_EQ(loadGltf(dir / "scene.gltf", report).meshes.size(), first.meshes.size());
    EXPECT_EQ(loadGltf(dir / "scene.gltf", report).meshes[0].vertices.front().position,
              first.meshes[0].vertices.front().position);
    // The next write completes the switch and removes the stale buffers.
    writeGltf(second, dir / "scene.gltf");
    EXPECT_EQ(bufferUri(dir / "scene.gltf"), secondBin);
    EXPECT_EQ(filesInDir(), (std::vector<std::string>{secondBin, "scene.gltf"}));
    EXPECT_EQ(loadGltf(dir / "scene.gltf", report).meshes.size(), second.meshes.size());
    EXPECT_EQ(loadGltf(dir / "scene.gltf", report).meshes[0].vertices.front().position,
              second.meshes[0].vertices.front().position);
    // Rewriting the same scene keeps the same name.
    writeGltf(second, dir / "scene.gltf");
    EXPECT_EQ(filesInDir(), (std::vector<std::string>{secondBin, "scene.gltf"}));
}
