// glTF loading against the hand-made files in data/gltf (data/gltf/README.md says what
// each holds): what loads must come out exactly as written, and each class of bad input
// must be refused with a message that names the file and the element.
#include "ScratchFolder.h"
#include "TestConfigs.h"

#include "penumbra/core/Error.h"
#include "penumbra/scene/GltfLoader.h"

#include <fmt/format.h>
#include <glm/gtc/matrix_transform.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include <cmath>
#include <fstream>

using namespace penumbra;
using test::expectNear;
using test::gltfFile;
using namespace penumbra::scene;
namespace fs = std::filesystem;

namespace {


Scene load(const std::string& name, GltfLoadReport& report, const GltfLoadOptions& options = {})
{
    return loadGltf(gltfFile(name), report, options);
}

// The AssetError message loading `path` gives; a test failure if it loads or throws
// anything else.
std::string errorOfPath(const fs::path& path, const GltfLoadOptions& options = {})
{
    GltfLoadReport report;
    try {
        loadGltf(path, report, options);
    } catch (const AssetError& e) {
        return e.what();
    }
    ADD_FAILURE() << path << " loaded";
    return {};
}

std::string loadErrorOf(const std::string& name, const GltfLoadOptions& options = {})
{
    return errorOfPath(gltfFile(name), options);
}

bool anyContains(const std::vector<std::string>& lines, const std::string& text)
{
    return std::any_of(lines.begin(), lines.end(), [&](const std::string& l) { return l.find(text) != std::string::npos; });
}

// quad.gltf's JSON, edited and written to a temporary file (its buffer is a data URI,
// so the copy stands alone).
class EditedQuad : public test::ScratchFolderTest {
protected:
    void SetUp() override
    {
        test::ScratchFolderTest::SetUp();
        std::ifstream in(gltfFile("quad.gltf"));
        doc = nlohmann::json::parse(in);
    }

    fs::path write()
    {
        const fs::path path = dir / "edited.gltf";
        std::ofstream(path) << doc.dump(1);
        return path;
    }

    nlohmann::json doc;
};

} // namespace

// Values a message echoes are shortened (issue 43: a 1 MB string became 1 MB of stderr):
// a name, an enum value, a version, an extension name of 100,000 characters each.
TEST_F(EditedQuad, EchoedValuesAreShortened)
{
    const nlohmann::json huge = std::string(100000, 'x'), quad = doc;
    for (const char* at : {"/materials/0/alphaMode", "/asset/version", "/extensionsRequired"}) {
        SCOPED_TRACE(at);
        doc = quad;
        doc[nlohmann::json::json_pointer(at)] = std::string(at) == "/extensionsRequired" ? nlohmann::json{huge, huge} : huge;
        const std::string e = errorOfPath(write());
        EXPECT_NE(e.find("characters)"), std::string::npos) << e.substr(0, 300);
        EXPECT_LT(e.size(), 1000u) << e.substr(0, 300);
    }
}

TEST(GltfLoader, QuadWithEmbeddedBuffer)
{
    GltfLoadReport report;
    const Scene scene = load("quad.gltf", report);
    ASSERT_EQ(scene.meshes.size(), 1u);
    const Mesh& mesh = scene.meshes[0];
    EXPECT_EQ(mesh.name, "quad");
    ASSERT_EQ(mesh.vertices.size(), 4u);
    EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{0, 2, 1, 0, 3, 2}));
    expectNear(mesh.vertices[2].position, {1, 0, 1});
    expectNear(mesh.vertices[2].normal, {0, 1, 0});
    EXPECT_EQ(mesh.vertices[2].uv, glm::vec2(1, 1));
    expectNear(mesh.bounds.min, {-1, 0, -1});
    expectNear(mesh.bounds.max, {1, 0, 1});

    const Material& material = scene.materials.at(mesh.material);
    EXPECT_EQ(material.name, "red");
    EXPECT_EQ(material.baseColor, glm::vec4(0.8f, 0.1f, 0.1f, 1.0f));
    EXPECT_EQ(material.alphaMode, AlphaMode::Opaque);
    EXPECT_FALSE(material.doubleSided);

    ASSERT_EQ(scene.instances.size(), 1u);
    EXPECT_EQ(scene.triangleCount(), 2u);
    ASSERT_EQ(report.meshes.size(), 1u);
    EXPECT_EQ(report.meshes[0].element, "/meshes/0/primitives/0");
    EXPECT_FALSE(report.meshes[0].repair.changedMesh());
    EXPECT_TRUE(report.warnings.empty()) << report.warnings.front();
}

TEST(GltfLoader, ExternalBufferAndGlbLoadTheSameQuad)
{
    GltfLoadReport report;
    const Scene embedded = load("quad.gltf", report);
    for (const char* name : {"quad_external.gltf", "quad.glb"}) {
        const Scene other = load(name, report);
        ASSERT_EQ(other.meshes.size(), 1u) << name;
        EXPECT_EQ(other.meshes[0].indices, embedded.meshes[0].indices) << name;
        ASSERT_EQ(other.meshes[0].vertices.size(), embedded.meshes[0].vertices.size()) << name;
        for (size_t i = 0; i < embedded.meshes[0].vertices.size(); ++i) {
            EXPECT_EQ(other.meshes[0].vertices[i].position, embedded.meshes[0].vertices[i].position) << name;
            EXPECT_EQ(other.meshes[0].vertices[i].uv, embedded.meshes[0].vertices[i].uv) << name;
        }
    }
}

TEST(GltfLoader, TexturedMaskedTwoSidedMaterial)
{
    GltfLoadReport report;
    const Scene scene = load("textured.gltf", report);
    ASSERT_EQ(scene.meshes.size(), 1u);
    const Material& material = scene.materials.at(scene.meshes[0].material);
    EXPECT_EQ(material.baseColor, glm::vec4(1.0f, 0.5f, 0.25f, 1.0f));
    EXPECT_EQ(material.alphaMode, AlphaMode::Mask);
    EXPECT_FLOAT_EQ(material.alphaCutoff, 0.25f);
    EXPECT_TRUE(material.doubleSided);
    ASSERT_EQ(material.baseColorTexture, 0);
    ASSERT_EQ(scene.textures.size(), 1u);
    const Texture& texture = scene.textures[0];
    EXPECT_EQ(texture.name, "checker");
    EXPECT_EQ(texture.width, 2u);
    EXPECT_EQ(texture.height, 2u);
    // Red, green / blue, half-transparent white, row by row.
    EXPECT_EQ(texture.rgba, (std::vector<uint8_t>{255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 255, 255, 255, 128}));
}

TEST(GltfLoader, HierarchyInAnyNodeOrderWithInstancingAndLights)
{
    GltfLoadReport report;
    const Scene scene = load("hierarchy.gltf", report);
    // Six nodes of the default scene; "unused" (not in it) is left out.
    ASSERT_EQ(scene.graph.size(), 6u);
    for (uint32_t n = 0; n < scene.graph.size(); ++n) EXPECT_LT(scene.graph.node(n).parent, int32_t(n));

    // One glTF mesh with two primitives under two nodes: two scene meshes, four instances.
    ASSERT_EQ(scene.meshes.size(), 2u);
    ASSERT_EQ(scene.instances.size(), 4u);
    EXPECT_EQ(scene.materials.at(scene.meshes[1].material).alphaMode, AlphaMode::Blend);
    EXPECT_FLOAT_EQ(scene.materials.at(scene.meshes[1].material).baseColor.a, 0.5f);
    std::vector<Aabb> quadBounds;
    for (const Instance& instance : scene.instances) {
        EXPECT_EQ(std::count_if(scene.instances.begin(), scene.instances.end(),
                                [&](const Instance& other) { return other.mesh == instance.mesh; }),
                  2);
        if (instance.mesh == 0) quadBounds.push_back(instance.worldBounds);
    }
    ASSERT_EQ(quadBounds.size(), 2u);
    // "right" (matrix: scale 2, then +3 in x) and "left" (translation -3), both under
    // "root" (translation +1 in y); depth-first order puts "right" first.
    expectNear(quadBounds[0].min, {1, 1, -2});
    expectNear(quadBounds[0].max, {5, 1, 2});
    expectNear(quadBounds[1].min, {-4, 1, -1});
    expectNear(quadBounds[1].max, {-2, 1, 1});

    ASSERT_EQ(report.lights.size(), 3u);
    auto light = [&](const std::string& name) {
        auto it = std::find_if(report.lights.begin(), report.lights.end(), [&](const GltfLight& l) { return l.name == name; });
        EXPECT_NE(it, report.lights.end()) << name;
        return it == report.lights.end() ? Light{} : it->light;
    };
    const Light sun = light("sun");
    EXPECT_EQ(sun.type, LightType::Directional);
    expectNear(sun.direction, {0, -1, 0});
    EXPECT_FLOAT_EQ(sun.intensity, 3.0f);
    expectNear(sun.color, {1.0f, 0.9f, 0.8f});
    const Light lamp = light("lamp");
    EXPECT_EQ(lamp.type, LightType::Spot);
    expectNear(lamp.position, {0, 6, 0});
    expectNear(lamp.direction, {0, -1, 0});
    EXPECT_NEAR(lamp.innerConeDeg, 0.3f * 180.0f / 3.14159265f, 1e-3f);
    EXPECT_NEAR(lamp.outerConeDeg, 0.6f * 180.0f / 3.14159265f, 1e-3f);
    EXPECT_FLOAT_EQ(lamp.intensity, 500.0f);
    const Light bulb = light("bulb");
    EXPECT_EQ(bulb.type, LightType::Point);
    expectNear(bulb.position, {1, 2, 3});

    // The second primitive is non-indexed with 4 vertices: one triangle and a warning.
    EXPECT_EQ(scene.meshes[1].indices.size(), 3u);
    EXPECT_TRUE(anyContains(report.warnings, "/meshes/0/primitives/1: 4 vertices (no indices) are not a multiple of 3"));
}

TEST(GltfLoader, WithoutDefaultSceneEveryRootIsLoaded)
{
    GltfLoadReport report;
    const Scene scene = load("no_scene.gltf", report);
    ASSERT_EQ(scene.graph.size(), 3u);
    EXPECT_EQ(scene.instances.size(), 2u);
    EXPECT_EQ(scene.graph.node(2).name, "c");
    EXPECT_EQ(scene.graph.node(scene.graph.node(2).parent).name, "b");
}

TEST(GltfLoader, StripsFansListsAndIndexTypes)
{
    GltfLoadReport report;
    const Scene scene = load("modes.gltf", report);
    // POINTS and LINES are refused per primitive, with a warning naming each.
    EXPECT_TRUE(anyContains(report.warnings, "/meshes/0/primitives/0: mode 0 (POINTS)"));
    EXPECT_TRUE(anyContains(report.warnings, "/meshes/0/primitives/1: mode 1 (LINES)"));
    ASSERT_EQ(scene.meshes.size(), 4u);
    const std::vector<uint32_t> strip{0, 1, 2, 1, 3, 2, 2, 3, 4};
    EXPECT_EQ(scene.meshes[0].indices, strip);                                                   // strip, u8
    EXPECT_EQ(scene.meshes[1].indices, (std::vector<uint32_t>{1, 2, 0, 2, 3, 0, 3, 4, 0}));     // fan, u16
    EXPECT_EQ(scene.meshes[2].indices, (std::vector<uint32_t>{0, 1, 2, 2, 3, 4}));              // list, u32
    EXPECT_EQ(scene.meshes[3].indices, strip);                                                   // strip, no indices
    // Every triangle faces +Y, so do the generated normals.
    for (const Mesh& mesh : scene.meshes) {
        for (const Vertex& v : mesh.vertices) expectNear(v.normal, {0, 1, 0});
    }
    EXPECT_EQ(report.meshes[0].repair.generatedNormals, 5u);
}

TEST(GltfLoader, InterleavedNormalizedTexcoordsAndSparsePositions)
{
    GltfLoadReport report;
    const Scene scene = load("interleaved_sparse.gltf", report);
    ASSERT_EQ(scene.meshes.size(), 2u);
    const std::vector<glm::vec2> uvs{{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    for (const Mesh& mesh : scene.meshes) {
        ASSERT_EQ(mesh.vertices.size(), 4u);
        for (size_t i = 0; i < 4; ++i) EXPECT_EQ(mesh.vertices[i].uv, uvs[i]) << mesh.name << " vertex " << i;
    }
    // Byte stride 16: positions read from every 16 bytes.
    expectNear(scene.meshes[0].vertices[2].position, {1, 0, 1});
    expectNear(scene.meshes[0].vertices[3].position, {-1, 0, 1});
    // The sparse accessor replaces vertex 2 only.
    expectNear(scene.meshes[1].vertices[2].position, {1, 2, 1});
    expectNear(scene.meshes[1].vertices[3].position, {-1, 0, 1});
}

TEST(GltfLoader, UnknownOptionalExtensionIsAWarning)
{
    GltfLoadReport report;
    const Scene scene = load("unknown_used_extension.gltf", report);
    EXPECT_EQ(scene.triangleCount(), 2u);
    EXPECT_TRUE(anyContains(report.warnings, "extension KHR_texture_transform is not supported; ignored"));
}

TEST(GltfLoader, NonFinitePositionsAreRepairedNotRefused)
{
    GltfLoadReport report;
    const Scene scene = load("non_finite.gltf", report);
    ASSERT_EQ(scene.meshes.size(), 1u);
    EXPECT_EQ(scene.meshes[0].indices.size(), 6u);
    EXPECT_EQ(report.meshes[0].repair.nonFiniteTriangles, 2u);
    EXPECT_EQ(report.meshes[0].repair.unusedVertices, 3u);
    expectNear(scene.bounds().min, {-1, 0, -1});
    expectNear(scene.bounds().max, {1, 0, 1});
    EXPECT_TRUE(anyContains(report.warnings, "2 triangle(s) with NaN or infinite corners dropped"));
}

// --- One test per class of bad input ---------------------------------------------

TEST(GltfLoaderErrors, MissingFile)
{
    EXPECT_NE(loadErrorOf("nope.gltf").find("nope.gltf: glTF file not found"), std::string::npos);
}

TEST(GltfLoaderErrors, MalformedJson)
{
    const std::string e = loadErrorOf("malformed.gltf");
    EXPECT_NE(e.find("malformed.gltf: malformed JSON: parse error at line 3, column 24"), std::string::npos) << e;
}

TEST(GltfLoaderErrors, MissingBinFile)
{
    const std::string e = loadErrorOf("missing_bin.gltf");
    EXPECT_NE(e.find("missing_bin.gltf: /buffers/0/uri: buffer file 'quad_missing.bin' not found (looked in "),
              std::string::npos)
        << e;
}

TEST(GltfLoaderErrors, MissingTextureFile)
{
    const std::string e = loadErrorOf("missing_texture.gltf");
    EXPECT_NE(e.find("missing_texture.gltf: /images/0: texture file 'checker_missing.png' not found"), std::string::npos) << e;
}

TEST(GltfLoaderErrors, AbsurdAccessorCountIsCheckedAgainstItsBufferView)
{
    const std::string e = loadErrorOf("huge_accessor.gltf");
    EXPECT_NE(e.find("huge_accessor.gltf: /accessors/0: count 4294967295 × 12 bytes exceeds buffer view 0 (128 bytes)"),
              std::string::npos)
        << e;
}

TEST(GltfLoaderErrors, BufferViewOutsideItsBuffer)
{
    const std::string e = loadErrorOf("bufferview_out_of_range.gltf");
    EXPECT_NE(e.find("bufferview_out_of_range.gltf: /bufferViews/1: byteOffset 128 + byteLength 400 exceeds buffer 0 (140 bytes)"),
              std::string::npos)
        << e;
}

TEST(GltfLoaderErrors, AccessorIndexOutOfRange)
{
    const std::string e = loadErrorOf("missing_accessor.gltf");
    EXPECT_NE(e.find("missing_accessor.gltf: /meshes/0/primitives/0/attributes/NORMAL: accessor 9 does not exist (4 accessors)"),
              std::string::npos)
        << e;
}

TEST(GltfLoaderErrors, VertexIndexOutOfRange)
{
    const std::string e = loadErrorOf("index_out_of_range.gltf");
    EXPECT_NE(e.find("index_out_of_range.gltf: /meshes/0/primitives/0/indices: index 7 at position 4 (accessor 3) is out of "
                     "range of 4 vertices"),
              std::string::npos)
        << e;
}

TEST(GltfLoaderErrors, NodeCycle)
{
    const std::string e = loadErrorOf("node_cycle.gltf");
    EXPECT_NE(e.find("node_cycle.gltf: /nodes/2: nodes form a cycle, each the parent of the next: node 2 'a' -> node 3 'b' -> "
                     "node 4 'c' -> node 2 'a'"),
              std::string::npos)
        << e;
}

TEST(GltfLoaderErrors, NodeWithTwoParents)
{
    const std::string e = loadErrorOf("two_parents.gltf");
    EXPECT_NE(e.find("two_parents.gltf: /nodes/2: node 2 'shared' has two parents: nodes 0 and 1"), std::string::npos) << e;
}

TEST(GltfLoaderErrors, UnsupportedRequiredExtension)
{
    const std::string e = loadErrorOf("draco_required.gltf");
    EXPECT_NE(e.find("draco_required.gltf: required extension KHR_draco_mesh_compression is not supported"), std::string::npos)
        << e;
}

TEST(GltfLoaderErrors, Gltf1IsRefused)
{
    for (const char* name : {"gltf1.gltf", "gltf1.glb"}) {
        const std::string e = loadErrorOf(name);
        EXPECT_NE(e.find(std::string(name) + ": glTF 1.0 is not supported"), std::string::npos) << e;
    }
}

TEST(GltfLoaderErrors, VertexAndTriangleLimits)
{
    GltfLoadOptions options;
    options.maxVertices = 3;
    std::string e = loadErrorOf("quad.gltf", options);
    EXPECT_NE(e.find("quad.gltf: /accessors/0: count 4 exceeds 3 (vertices left of the limit of 3 per file)"),
              std::string::npos)
        << e;
    options = {};
    options.maxTriangles = 1;
    e = loadErrorOf("quad.gltf", options);
    EXPECT_NE(e.find("quad.gltf: /accessors/3: count 6 exceeds 5 (indices for the 1 triangles left of the limit of 1 per file)"),
              std::string::npos)
        << e;
    // A strip of t triangles has t + 2 indices.
    options.maxTriangles = 0;
    e = loadErrorOf("modes.gltf", options);
    EXPECT_NE(e.find("modes.gltf: /accessors/1: count 5 exceeds 2"), std::string::npos) << e;
}

TEST(GltfLoaderErrors, TextureSizeLimitBeforeDecoding)
{
    GltfLoadOptions options;
    options.maxImageTexels = 3;
    std::string e = loadErrorOf("textured.gltf", options);
    EXPECT_NE(e.find("textured.gltf: /images/0: 2×2 texels exceed the limit of 3 per image"), std::string::npos) << e;
    options = {};
    options.maxTotalTexels = 3;
    e = loadErrorOf("textured.gltf", options);
    EXPECT_NE(e.find("textured.gltf: /images/0: 2×2 texels exceed the 3 left of the limit for all the file's images"),
              std::string::npos)
        << e;
}

TEST(GltfLoaderErrors, BytesReadLimit)
{
    GltfLoadOptions options;
    options.maxBytesRead = 100;
    std::string e = loadErrorOf("quad.gltf", options);
    EXPECT_NE(e.find("quad.gltf: is 1534 bytes, more than the 100 bytes a glTF file may hold"), std::string::npos) << e;
    // quad_external.gltf (1317 bytes) fits, quad.bin (140 bytes) then does not: refused by
    // its size, before it is read.
    options.maxBytesRead = 1400;
    e = loadErrorOf("quad_external.gltf", options);
    EXPECT_NE(e.find("quad_external.gltf: /buffers/0/uri: buffer file 'quad.bin' is 140 bytes, more than the 83 bytes a "
                     "glTF buffer may hold (what is left of the 1400 bytes a glTF model may read in all)"),
              std::string::npos)
        << e;
    options.maxBytesRead = 1317 + 140;
    GltfLoadReport report;
    EXPECT_EQ(loadGltf(gltfFile("quad_external.gltf"), report, options).triangleCount(), 2u);
}

TEST(GltfLoaderErrors, InstanceLimit)
{
    GltfLoadOptions options;
    options.maxInstances = 3;
    const std::string e = loadErrorOf("hierarchy.gltf", options);
    EXPECT_NE(e.find("hierarchy.gltf: /nodes/0/mesh: instances exceed the limit of 3 per file"), std::string::npos) << e;
}

TEST_F(EditedQuad, TruncatedGlb)
{
    const fs::path path = dir / "short.glb";
    std::ofstream(path, std::ios::binary) << "glTF\x02";
    const std::string e = errorOfPath(path);
    EXPECT_NE(e.find("short.glb: GLB header truncated (5 bytes)"), std::string::npos) << e;
}

TEST_F(EditedQuad, AttributeOfTheWrongType)
{
    doc["accessors"][0]["type"] = "VEC2";
    const std::string e = errorOfPath(write());
    EXPECT_NE(e.find("/meshes/0/primitives/0/attributes/POSITION: accessor 0 is VEC2 of FLOAT; POSITION must be VEC3 of FLOAT"),
              std::string::npos)
        << e;
}

TEST_F(EditedQuad, ByteStrideSmallerThanTheElement)
{
    doc["bufferViews"][0]["byteStride"] = 8;
    const std::string e = errorOfPath(write());
    EXPECT_NE(e.find("/bufferViews/0: byteStride 8 is smaller than accessor 0's 12-byte elements"), std::string::npos) << e;
}

TEST_F(EditedQuad, SparseIndexOutOfRange)
{
    // Sparse indices and values taken from the index buffer view (u16 0, 2, 1, ...).
    doc["accessors"][0]["sparse"] = {{"count", 1},
                                     {"indices", {{"bufferView", 1}, {"byteOffset", 2}, {"componentType", 5123}}},
                                     {"values", {{"bufferView", 0}}}};
    doc["accessors"][0]["count"] = 2;
    doc["accessors"][1]["count"] = 2;
    doc["accessors"][2]["count"] = 2;
    doc["accessors"][3]["count"] = 0;
    const std::string e = errorOfPath(write());
    EXPECT_NE(e.find("/accessors/0/sparse/indices: index 2 at position 0 is out of range of 2 elements"), std::string::npos)
        << e;
}

TEST_F(EditedQuad, UnknownAlphaMode)
{
    doc["materials"][0]["alphaMode"] = "CUTOUT";
    const std::string e = errorOfPath(write());
    EXPECT_NE(e.find("/materials/0/alphaMode: 'CUTOUT' is not OPAQUE, MASK or BLEND"), std::string::npos) << e;
}

TEST_F(EditedQuad, SceneRootThatIsAChild)
{
    doc["nodes"].push_back({{"name", "parent"}, {"children", {0}}});
    doc["scenes"][0]["nodes"] = {1, 0};
    const std::string e = errorOfPath(write());
    EXPECT_NE(e.find("/scenes/0/nodes/1: node 0 'quad' is a child of node 1; a scene lists root nodes only"), std::string::npos)
        << e;
}

TEST_F(EditedQuad, BadSpotCone)
{
    doc["extensions"]["KHR_lights_punctual"]["lights"] = {
        {{"type", "spot"}, {"spot", {{"innerConeAngle", 0.8}, {"outerConeAngle", 0.4}}}}};
    doc["nodes"][0]["extensions"]["KHR_lights_punctual"]["light"] = 0;
    const std::string e = errorOfPath(write());
    EXPECT_NE(e.find("/extensions/KHR_lights_punctual/lights/0/spot: innerConeAngle 0.8 and outerConeAngle 0.4 must satisfy"),
              std::string::npos)
        << e;
}

TEST_F(EditedQuad, UnusedMaterialsAndImagesCannotFailTheLoad)
{
    doc["materials"].push_back({{"name", "unused"}, {"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}});
    doc["textures"] = {{{"source", 0}}};
    doc["images"] = {{{"uri", "not_there.png"}}};
    GltfLoadReport report;
    const Scene scene = loadGltf(write(), report);
    EXPECT_EQ(scene.triangleCount(), 2u);
    EXPECT_TRUE(scene.textures.empty());
}

// JSON nested past kMaxGltfNesting in `extras` or `extensions` (anything goes there) is
// refused by a scan of the text before tinygltf parses it: its conversion of extras
// recursed per level, and ~15,000 levels overflowed the stack. Within the limit it loads.
TEST_F(EditedQuad, NestingInExtrasIsLimitedBeforeParsing)
{
    // The edited quad's own JSON nests 5 levels at most below its root, so `extras` of a
    // node at /nodes/0/extras adds 3 (the root, "nodes", the node) to its own levels.
    for (const char* where : {"/nodes/0/extras", "/meshes/0/extensions"}) {
        for (bool arrays : {false, true}) {
            for (int levels : {kMaxGltfNesting - 3, kMaxGltfNesting - 2, 15000}) {
                SCOPED_TRACE(testing::Message() << where << (arrays ? " arrays " : " objects ") << levels);
                nlohmann::json edited = doc;
                const nlohmann::json::json_pointer at(where);
                edited[at] = arrays ? nlohmann::json::array({"@@DEEP@@"}) : nlohmann::json::object({{"deep", "@@DEEP@@"}});
                std::string text = edited.dump();
                const std::string inner = test::nestedJson(levels - 1, arrays);
                text.replace(text.find("\"@@DEEP@@\""), 10, inner);
                for (bool glb : {false, true}) {
                    const fs::path path = dir / (glb ? "deep.glb" : "deep.gltf");
                    std::ofstream out(path, std::ios::binary);
                    if (glb) {
                        while (text.size() % 4) text += ' ';
                        const uint32_t length = uint32_t(12 + 8 + text.size()), json = uint32_t(text.size());
                        out.write("glTF", 4);
                        const uint32_t version = 2, type = 0x4E4F534A;  // "JSON"
                        out.write(reinterpret_cast<const char*>(&version), 4);
                        out.write(reinterpret_cast<const char*>(&length), 4);
                        out.write(reinterpret_cast<const char*>(&json), 4);
                        out.write(reinterpret_cast<const char*>(&type), 4);
                    }
                    out << text;
                    out.close();
                    GltfLoadReport report;
                    if (levels <= kMaxGltfNesting - 3) {
                        EXPECT_NO_THROW(loadGltf(path, report)) << path;
                    } else {
                        const std::string e = errorOfPath(path);
                        EXPECT_NE(e.find(path.filename().string() + ": its JSON nests objects and arrays deeper than 256"),
                                  std::string::npos)
                            << e.substr(0, 300);
                    }
                }
            }
        }
    }
}

// What tinygltf reported without a JSON path (or with a whole base64 payload), what it
// dropped silently, and sizes the limits refuse anyway: each is named before tinygltf
// loads the file (scene/gltf/Preflight.h), before any external buffer is read.
TEST_F(EditedQuad, PreflightNamesWhatTinygltfWouldNot)
{
    // A byteLength beyond the data URI: named, without the payload.
    doc["buffers"][0]["byteLength"] = doc["buffers"][0]["byteLength"].get<int>() + 1000;
    std::string e = errorOfPath(write());
    EXPECT_NE(e.find("edited.gltf: /buffers/0: byteLength 1140 exceeds the 140 bytes its data URI holds"), std::string::npos)
        << e;
    EXPECT_EQ(e.find("base64"), std::string::npos) << e;
    SetUp();
    // An indices accessor the file does not have.
    doc["meshes"][0]["primitives"][0]["indices"] = 99;
    e = errorOfPath(write());
    EXPECT_NE(e.find("edited.gltf: /meshes/0/primitives/0/indices: accessor 99 does not exist (4 accessors)"),
              std::string::npos)
        << e;
    SetUp();
    // A primitive without attributes: refused, not dropped into a file of no triangles.
    doc["meshes"][0]["primitives"][0].erase("attributes");
    e = errorOfPath(write());
    EXPECT_NE(e.find("edited.gltf: /meshes/0/primitives/0: has no \"attributes\" object"), std::string::npos) << e;
}

TEST_F(EditedQuad, ExternalBufferSizesAreCheckedBeforeItIsRead)
{
    // quad_external.gltf with its quad.bin copied beside it.
    std::ifstream in(gltfFile("quad_external.gltf"));
    nlohmann::json external = nlohmann::json::parse(in);
    fs::copy_file(gltfFile("quad.bin"), dir / "quad.bin");
    const uint64_t binBytes = fs::file_size(dir / "quad.bin");
    // A byteLength beyond the file.
    external["buffers"][0]["byteLength"] = binBytes + 8;
    std::ofstream(dir / "long.gltf") << external.dump();
    std::string e = errorOfPath(dir / "long.gltf");
    EXPECT_NE(e.find(fmt::format("long.gltf: /buffers/0: byteLength {} exceeds the {} bytes of its file 'quad.bin'",
                                 binBytes + 8, binBytes)),
              std::string::npos)
        << e;
    // The vertex limit refuses the file before the buffer is read: with a byte budget the
    // .bin would overrun, the limit is what is reported.
    external["buffers"][0]["byteLength"] = binBytes;
    std::ofstream(dir / "limited.gltf") << external.dump();
    GltfLoadOptions options;
    options.maxVertices = 3;
    options.maxBytesRead = fs::file_size(dir / "limited.gltf") + binBytes / 2;
    e = errorOfPath(dir / "limited.gltf", options);
    EXPECT_NE(e.find("limited.gltf: /accessors/0: count 4 exceeds 3 (vertices left of the limit of 3 per file)"),
              std::string::npos)
        << e;
}
