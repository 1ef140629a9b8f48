// Mesh repair: what is dropped, merged and generated, against hand-computed results and
// a plain reference for the area-weighted normals.
#include "TestConfigs.h"

#include "penumbra/core/Error.h"
#include "penumbra/scene/MeshRepair.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

using namespace penumbra;
using test::kInf;
using test::kNaN;
using test::expectNear;
using namespace penumbra::scene;

namespace {


Mesh meshOf(const std::vector<glm::vec3>& positions, std::vector<uint32_t> indices, glm::vec3 normal = glm::vec3(0.0f))
{
    Mesh mesh;
    mesh.name = "test";
    for (const glm::vec3& p : positions) mesh.vertices.push_back({p, normal, glm::vec2(0.0f)});
    mesh.indices = std::move(indices);
    return mesh;
}

// Reference: each vertex's normal is the normalized sum of (b - a) × (c - a) over its
// triangles, i.e. weighted by twice their area.
std::vector<glm::vec3> areaWeightedNormals(const Mesh& mesh)
{
    std::vector<glm::dvec3> sum(mesh.vertices.size(), glm::dvec3(0.0));
    for (size_t t = 0; t < mesh.indices.size(); t += 3) {
        const glm::dvec3 a = mesh.vertices[mesh.indices[t]].position, b = mesh.vertices[mesh.indices[t + 1]].position,
                         c = mesh.vertices[mesh.indices[t + 2]].position;
        const glm::dvec3 n = glm::cross(b - a, c - a);
        for (size_t k = 0; k < 3; ++k) sum[mesh.indices[t + k]] += n;
    }
    std::vector<glm::vec3> out;
    for (const glm::dvec3& s : sum) out.push_back(glm::vec3(glm::normalize(s)));
    return out;
}

} // namespace

TEST(MeshRepair, DropsNonFiniteAndDegenerateTriangles)
{
    // A unit quad (kept), then: a NaN corner, an infinite corner, three collinear
    // points, a repeated index, and a sliver of area 1e-14 (below 1e-12 · d², d = √2).
    Mesh mesh = meshOf({{0, 0, 0}, {1, 0, 0}, {1, 0, 1}, {0, 0, 1}, {kNaN, 0, 0}, {0, kInf, 0}, {0.5f, 0, 0},
                        {0.5f, 0, 2e-14f}},
                       {0, 2, 1, 0, 3, 2, 0, 4, 1, 5, 2, 3, 0, 6, 1, 0, 0, 2, 0, 1, 7});
    const RepairReport r = repairMesh(mesh);
    EXPECT_EQ(r.nonFiniteTriangles, 2u);
    EXPECT_EQ(r.degenerateTriangles, 3u);
    EXPECT_EQ(r.unusedVertices, 4u);
    EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{0, 2, 1, 0, 3, 2}));
    ASSERT_EQ(mesh.vertices.size(), 4u);
    expectNear(mesh.bounds.min, {0, 0, 0});
    expectNear(mesh.bounds.max, {1, 0, 1});
}

TEST(MeshRepair, DegenerateThresholdIsRelativeToTheMeshSize)
{
    // A triangle of relative area 1e-10 is kept, one of 1e-14 dropped, at any scale.
    for (float scale : {1e-4f, 1.0f, 1e4f}) {
        Mesh mesh = meshOf({{0, 0, 0}, {scale, 0, 0}, {0, 0, scale}, {scale, 0, 2e-10f * scale}, {scale, 0, 2e-14f * scale}},
                           {0, 2, 1, 0, 1, 3, 0, 1, 4});
        const RepairReport r = repairMesh(mesh);
        EXPECT_EQ(r.degenerateTriangles, 1u) << "scale " << scale;
        EXPECT_EQ(mesh.indices.size(), 6u) << "scale " << scale;
    }
}

TEST(MeshRepair, GeneratedNormalsAreAreaWeighted)
{
    // Two triangles on the z axis edge: one in y = 0 with twice the area of one in x = 0.
    // The shared vertices get normalize((0, 2, 0) + (1, 0, 0)), not the unweighted (1, 1, 0).
    Mesh mesh = meshOf({{0, 0, 0}, {0, 0, 1}, {2, 0, 0}, {0, 1, 0}}, {0, 1, 2, 1, 0, 3});
    const RepairReport r = repairMesh(mesh);
    EXPECT_EQ(r.generatedNormals, 4u);
    EXPECT_TRUE(r.topologyAnalyzed);
    const glm::vec3 shared = glm::normalize(glm::vec3(1, 2, 0));
    expectNear(mesh.vertices[0].normal, shared);
    expectNear(mesh.vertices[1].normal, shared);
    expectNear(mesh.vertices[2].normal, {0, 1, 0});
    expectNear(mesh.vertices[3].normal, {1, 0, 0});
}

TEST(MeshRepair, GeneratedNormalsMatchTheReferenceOnABumpyOpenGrid)
{
    // 4×4 vertices, heights varying: interior, edge and corner (boundary) vertices.
    std::vector<glm::vec3> positions;
    std::vector<uint32_t> indices;
    for (int z = 0; z < 4; ++z) {
        for (int x = 0; x < 4; ++x) positions.push_back({float(x), 0.3f * std::sin(float(x * 3 + z * 5)), float(z)});
    }
    for (uint32_t z = 0; z < 3; ++z) {
        for (uint32_t x = 0; x < 3; ++x) {
            const uint32_t a = z * 4 + x, b = a + 1, c = a + 4, d = c + 1;
            indices.insert(indices.end(), {a, c, b, b, c, d});
        }
    }
    Mesh mesh = meshOf(positions, indices);
    const std::vector<glm::vec3> expected = areaWeightedNormals(mesh);
    const RepairReport r = repairMesh(mesh);
    EXPECT_EQ(r.generatedNormals, 16u);
    EXPECT_EQ(r.boundaryEdges, 12u);
    for (size_t i = 0; i < expected.size(); ++i) expectNear(mesh.vertices[i].normal, expected[i]);
}

TEST(MeshRepair, ReplacesNaNNormalsAndNormalizesLongOnes)
{
    Mesh mesh = meshOf({{0, 0, 0}, {1, 0, 0}, {0, 0, -1}}, {0, 1, 2}, {0, 1, 0});
    mesh.vertices[1].normal = {kNaN, 0, 0};
    mesh.vertices[2].normal = {0, 3, 0};
    const RepairReport r = repairMesh(mesh);
    EXPECT_EQ(r.replacedNormals, 1u);
    EXPECT_EQ(r.renormalizedNormals, 1u);
    EXPECT_EQ(r.generatedNormals, 0u);
    // The valid normal stays exactly as it was.
    EXPECT_EQ(mesh.vertices[0].normal, glm::vec3(0, 1, 0));
    expectNear(mesh.vertices[1].normal, {0, 1, 0});
    expectNear(mesh.vertices[2].normal, {0, 1, 0});
}

TEST(MeshRepair, WeldMergesCoincidentVerticesWithEqualAttributes)
{
    // Two triangles of a quad, each with its own corners; the diagonal's two vertex
    // pairs coincide (one within 1e-7 · d), but the pair at x = 1 has different uvs.
    Mesh mesh = meshOf({{0, 0, 0}, {1, 0, 1}, {1, 0, 0}, {1e-7f, 0, 0}, {0, 0, 1}, {1, 0, 1}}, {0, 1, 2, 3, 4, 5},
                       {0, 1, 0});
    mesh.vertices[5].uv = {0.5f, 0.5f};
    Mesh unwelded = mesh;
    RepairOptions options;
    options.analyzeTopology = true;
    const RepairReport before = repairMesh(unwelded, options);
    EXPECT_EQ(before.weldedVertices, 0u);
    EXPECT_EQ(before.boundaryEdges, 6u);

    options.weld = true;
    const RepairReport after = repairMesh(mesh, options);
    EXPECT_EQ(after.weldedVertices, 1u);
    EXPECT_EQ(mesh.vertices.size(), 5u);
    EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{0, 1, 2, 0, 3, 4}));
    // The quad's diagonal is shared only where both ends merged: still open there.
    EXPECT_EQ(after.boundaryEdges, 6u);
    // With equal uvs the diagonal closes.
    Mesh same = meshOf({{0, 0, 0}, {1, 0, 1}, {1, 0, 0}, {1e-7f, 0, 0}, {0, 0, 1}, {1, 0, 1}}, {0, 1, 2, 3, 4, 5}, {0, 1, 0});
    const RepairReport closed = repairMesh(same, options);
    EXPECT_EQ(closed.weldedVertices, 2u);
    EXPECT_EQ(closed.boundaryEdges, 4u);
}

TEST(MeshRepair, WeldFindsNeighboursAcrossGridCells)
{
    // The shared corner of two triangles, once just below the origin on every axis and
    // once just above: 1.39e-6 apart, inside the weld radius 1e-6 · d (d ≈ 2.24), but
    // in different grid cells on all three axes.
    const float e = 4e-7f;
    Mesh mesh = meshOf({{-e, -e, -e}, {0, 0, 1}, {1, 0, 0}, {e, e, e}, {1, 0, 0}, {0, 0, -1}}, {0, 1, 2, 3, 4, 5},
                       {0, 1, 0});
    RepairOptions options;
    options.weld = true;
    const RepairReport r = repairMesh(mesh, options);
    EXPECT_EQ(r.weldedVertices, 2u);
    EXPECT_EQ(mesh.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3}));
}

TEST(MeshRepair, TopologyCountsOpenAndNonManifoldEdges)
{
    RepairOptions options;
    options.analyzeTopology = true;
    // A closed tetrahedron, outward-facing.
    Mesh tetra = meshOf({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3}, {1, 0, 0});
    RepairReport r = repairMesh(tetra, options);
    EXPECT_EQ(r.boundaryEdges, 0u);
    EXPECT_EQ(r.nonManifoldTriangles, 0u);

    // A fin: a third triangle on the edge two triangles already share.
    Mesh fin = meshOf({{0, 0, 0}, {1, 0, 0}, {0.5f, 1, 0}, {0.5f, -1, 0}, {0.5f, 0, 1}}, {0, 1, 2, 1, 0, 3, 0, 1, 4},
                      glm::vec3(0.0f));
    r = repairMesh(fin, options);
    EXPECT_EQ(r.nonManifoldTriangles, 1u);
    EXPECT_EQ(r.boundaryEdges, 4u);
    // It still gets normals, from all three triangles.
    for (const Vertex& v : fin.vertices) EXPECT_NEAR(glm::length(v.normal), 1.0f, 1e-5f);
    EXPECT_EQ(fin.indices.size(), 9u);
}

TEST(MeshRepair, AllBadMeshEndsEmpty)
{
    Mesh mesh = meshOf({{kNaN, 0, 0}, {1, 0, 0}, {0, 0, 1}}, {0, 1, 2});
    const RepairReport r = repairMesh(mesh);
    EXPECT_EQ(r.nonFiniteTriangles, 1u);
    EXPECT_TRUE(mesh.indices.empty());
    EXPECT_TRUE(mesh.vertices.empty());
    EXPECT_TRUE(mesh.bounds.empty());
}

TEST(MeshRepair, InvalidTriangleListThrows)
{
    Mesh outOfRange = meshOf({{0, 0, 0}, {1, 0, 0}, {0, 0, 1}}, {0, 1, 3});
    EXPECT_THROW(repairMesh(outOfRange), Error);
    Mesh partial = meshOf({{0, 0, 0}, {1, 0, 0}, {0, 0, 1}}, {0, 1});
    EXPECT_THROW(repairMesh(partial), Error);
}
