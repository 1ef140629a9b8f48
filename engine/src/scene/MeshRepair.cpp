#include "penumbra/scene/MeshRepair.h"

#include "penumbra/core/Error.h"
#include "core/Finite.h"

#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <unordered_map>

namespace penumbra::scene {
namespace {

using TopologyMesh = OpenMesh::TriMesh_ArrayKernelT<>;

using core::isFinite;

// The glTF loader writes a zero normal where the file has none.
enum class NormalState { Valid, Missing, NonFinite };

NormalState normalState(const glm::vec3& n)
{
    if (!isFinite(n)) return NormalState::NonFinite;
    return glm::dot(n, n) < 1e-12f ? NormalState::Missing : NormalState::Valid;
}

void checkTriangleList(const Mesh& mesh)
{
    if (mesh.indices.size() % 3 != 0) {
        throw Error(fmt::format("mesh '{}': {} indices are not a whole number of triangles", mesh.name, mesh.indices.size()));
    }
    for (size_t i = 0; i < mesh.indices.size(); ++i) {
        if (mesh.indices[i] >= mesh.vertices.size()) {
            throw Error(fmt::format("mesh '{}': index {} at position {} is out of range of {} vertices", mesh.name,
                                    mesh.indices[i], i, mesh.vertices.size()));
        }
    }
}

// The diagonal of the box around the finite vertices that triangles use (double: a
// float diagonal of a 1e38-wide box overflows).
double referencedDiagonal(const Mesh& mesh)
{
    glm::dvec3 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
    bool any = false;
    for (uint32_t i : mesh.indices) {
        const glm::vec3& p = mesh.vertices[i].position;
        if (!isFinite(p)) continue;
        lo = glm::min(lo, glm::dvec3(p));
        hi = glm::max(hi, glm::dvec3(p));
        any = true;
    }
    return any ? glm::length(hi - lo) : 0.0;
}

// Drops triangles with a non-finite corner, then those with area <= rel · d².
void dropBadTriangles(Mesh& mesh, double degenerateAreaRel, RepairReport& report)
{
    const double d = referencedDiagonal(mesh);
    // area = |(b - a) × (c - a)| / 2
    const double maxCrossLength = 2.0 * degenerateAreaRel * d * d;
    std::vector<uint32_t> kept;
    kept.reserve(mesh.indices.size());
    for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
        const uint32_t* corner = &mesh.indices[t];
        const glm::vec3& a = mesh.vertices[corner[0]].position;
        const glm::vec3& b = mesh.vertices[corner[1]].position;
        const glm::vec3& c = mesh.vertices[corner[2]].position;
        if (!isFinite(a) || !isFinite(b) || !isFinite(c)) {
            ++report.nonFiniteTriangles;
            continue;
        }
        const glm::dvec3 cross = glm::cross(glm::dvec3(b) - glm::dvec3(a), glm::dvec3(c) - glm::dvec3(a));
        if (glm::length(cross) <= maxCrossLength) {
            ++report.degenerateTriangles;
            continue;
        }
        kept.insert(kept.end(), corner, corner + 3);
    }
    mesh.indices.swap(kept);
}

// Keeps the vertices some triangle uses, in their order.
void removeUnusedVertices(Mesh& mesh, RepairReport& report)
{
    constexpr uint32_t kUnused = ~0u;
    std::vector<uint32_t> remap(mesh.vertices.size(), kUnused);
    for (uint32_t i : mesh.indices) remap[i] = 0;
    std::vector<Vertex> kept;
    kept.reserve(mesh.vertices.size());
    for (size_t i = 0; i < mesh.vertices.size(); ++i) {
        if (remap[i] == kUnused) continue;
        remap[i] = static_cast<uint32_t>(kept.size());
        kept.push_back(mesh.vertices[i]);
    }
    report.unusedVertices += static_cast<uint32_t>(mesh.vertices.size() - kept.size());
    for (uint32_t& i : mesh.indices) i = remap[i];
    mesh.vertices.swap(kept);
}

bool sameAttributes(const Vertex& a, const Vertex& b)
{
    constexpr float kUvTolerance = 1e-6f;
    constexpr float kNormalTolerance = 1e-3f;
    if (glm::any(glm::greaterThan(glm::abs(a.uv - b.uv), glm::vec2(kUvTolerance)))) return false;
    const NormalState sa = normalState(a.normal), sb = normalState(b.normal);
    if (sa != sb || sa == NormalState::NonFinite) return false;
    return sa == NormalState::Missing || !glm::any(glm::greaterThan(glm::abs(a.normal - b.normal), glm::vec3(kNormalTolerance)));
}

struct Cell {
    int64_t x, y, z;
    bool operator==(const Cell&) const = default;
};

struct CellHash {
    size_t operator()(const Cell& c) const
    {
        return size_t(uint64_t(c.x) * 73856093u ^ uint64_t(c.y) * 19349663u ^ uint64_t(c.z) * 83492791u);
    }
};

// Greedy clustering on a grid of cells two weld radii wide: a vertex joins the first
// earlier kept vertex within the radius whose attributes agree, or is kept itself.
// Within a radius of half a cell, a match lies in the vertex's own cell or, on each
// axis, the neighbour on the side of the cell's centre the vertex is not: 8 cells.
void weldVertices(Mesh& mesh, double weldDistanceRel, RepairReport& report)
{
    const double radius = weldDistanceRel * referencedDiagonal(mesh);
    const double cellSize = radius > 0.0 ? 2.0 * radius : 1.0;
    std::unordered_map<Cell, std::vector<uint32_t>, CellHash> grid;
    grid.reserve(mesh.vertices.size());
    std::vector<uint32_t> remap(mesh.vertices.size());
    std::vector<Vertex> kept;
    kept.reserve(mesh.vertices.size());
    for (size_t i = 0; i < mesh.vertices.size(); ++i) {
        const Vertex& v = mesh.vertices[i];
        int64_t cell[3], side[3];
        for (int axis = 0; axis < 3; ++axis) {
            // Clamped: a tiny radius beside huge coordinates must not overflow int64.
            const double t = std::clamp(double(v.position[axis]) / cellSize, -4e18, 4e18);
            cell[axis] = int64_t(std::floor(t));
            side[axis] = t - std::floor(t) < 0.5 ? -1 : 1;
        }
        const Cell home{cell[0], cell[1], cell[2]};
        uint32_t match = ~0u;
        for (int corner = 0; corner < 8 && match == ~0u; ++corner) {
            const Cell near{cell[0] + (corner & 1 ? side[0] : 0), cell[1] + (corner & 2 ? side[1] : 0),
                            cell[2] + (corner & 4 ? side[2] : 0)};
            auto it = grid.find(near);
            if (it == grid.end()) continue;
            for (uint32_t k : it->second) {
                const glm::dvec3 delta = glm::dvec3(kept[k].position) - glm::dvec3(v.position);
                if (glm::dot(delta, delta) <= radius * radius && sameAttributes(kept[k], v)) {
                    match = k;
                    break;
                }
            }
        }
        if (match == ~0u) {
            match = static_cast<uint32_t>(kept.size());
            grid[home].push_back(match);
            kept.push_back(v);
        }
        remap[i] = match;
    }
    report.weldedVertices += static_cast<uint32_t>(mesh.vertices.size() - kept.size());
    for (uint32_t& i : mesh.indices) i = remap[i];
    mesh.vertices.swap(kept);
}

// add_face reports every refused triangle on OpenMesh's error stream; the refusals are
// counted in the report instead.
class QuietOpenMeshErrors {
public:
    QuietOpenMeshErrors() : wasEnabled_(::omerr().is_enabled()) { ::omerr().disable(); }
    ~QuietOpenMeshErrors()
    {
        if (wasEnabled_) ::omerr().enable();
    }
    QuietOpenMeshErrors(const QuietOpenMeshErrors&) = delete;
    QuietOpenMeshErrors& operator=(const QuietOpenMeshErrors&) = delete;

private:
    bool wasEnabled_;
};

// The mesh as an OpenMesh half-edge structure. A triangle that cannot join the
// manifold surface (a third triangle on an edge, or one flipped against its
// neighbours) is added apart, on copies of its corners, as OpenMesh's own file
// readers do, so that it still contributes to its vertices' normals.
struct Topology {
    TopologyMesh mesh;
    std::vector<uint32_t> source;    // topology vertex -> Mesh vertex
    std::vector<uint8_t> apart;      // per topology face: added apart from the surface
};

Topology buildTopology(const Mesh& mesh, RepairReport& report)
{
    Topology topo;
    const size_t triangles = mesh.indices.size() / 3;
    topo.mesh.reserve(mesh.vertices.size(), triangles * 3 / 2, triangles);
    topo.source.reserve(mesh.vertices.size());
    auto addVertex = [&](uint32_t i) {
        const glm::vec3& p = mesh.vertices[i].position;
        topo.source.push_back(i);
        return topo.mesh.add_vertex(TopologyMesh::Point(p.x, p.y, p.z));
    };
    std::vector<TopologyMesh::VertexHandle> handles;
    handles.reserve(mesh.vertices.size());
    for (uint32_t i = 0; i < mesh.vertices.size(); ++i) handles.push_back(addVertex(i));

    QuietOpenMeshErrors quiet;
    for (size_t t = 0; t < triangles; ++t) {
        const uint32_t* c = &mesh.indices[3 * t];
        TopologyMesh::FaceHandle face = topo.mesh.add_face(handles[c[0]], handles[c[1]], handles[c[2]]);
        const bool joined = face.is_valid();
        if (!joined) {
            ++report.nonManifoldTriangles;
            face = topo.mesh.add_face(addVertex(c[0]), addVertex(c[1]), addVertex(c[2]));
        }
        topo.apart.resize(size_t(face.idx()) + 1, 0);
        topo.apart[size_t(face.idx())] = joined ? 0 : 1;
    }
    for (auto edge : topo.mesh.edges()) {
        if (!topo.mesh.is_boundary(edge)) continue;
        const auto inner = topo.mesh.is_boundary(edge.h0()) ? edge.h1() : edge.h0();
        report.boundaryEdges += topo.apart[size_t(inner.face().idx())] ? 0 : 1;
    }
    report.topologyAnalyzed = true;
    return topo;
}

// Area-weighted vertex normals (OpenMesh's calc_normal sums the corner sectors'
// cross products, whose length is twice the triangle area) for every vertex whose
// normal is missing or not finite.
void fillNormals(Mesh& mesh, const Topology& topo, RepairReport& report)
{
    std::vector<glm::vec3> sum(mesh.vertices.size(), glm::vec3(0.0f));
    std::vector<glm::vec3> fallback(mesh.vertices.size(), glm::vec3(0.0f, 1.0f, 0.0f));
    for (auto vertex : topo.mesh.vertices()) {
        const uint32_t i = topo.source[size_t(vertex.idx())];
        if (normalState(mesh.vertices[i].normal) == NormalState::Valid) continue;
        const TopologyMesh::Normal n = topo.mesh.calc_normal(vertex);
        sum[i] += glm::vec3(n[0], n[1], n[2]);
        for (auto face : vertex.faces()) {
            const TopologyMesh::Normal f = topo.mesh.calc_face_normal(face);
            fallback[i] = glm::vec3(f[0], f[1], f[2]);
            break;
        }
    }
    for (size_t i = 0; i < mesh.vertices.size(); ++i) {
        glm::vec3& normal = mesh.vertices[i].normal;
        const NormalState state = normalState(normal);
        if (state == NormalState::Valid) continue;
        // A vertex shared by opposite triangles (a two-sided sheet) sums to zero.
        const float length = glm::length(sum[i]);
        normal = std::isfinite(length) && length > 1e-6f ? sum[i] / length : fallback[i];
        ++(state == NormalState::Missing ? report.generatedNormals : report.replacedNormals);
    }
}

void normalizeNormals(Mesh& mesh, RepairReport& report)
{
    for (Vertex& v : mesh.vertices) {
        if (normalState(v.normal) != NormalState::Valid) continue;
        const float length = glm::length(v.normal);
        if (std::abs(length - 1.0f) <= 1e-3f) continue;
        v.normal /= length;
        ++report.renormalizedNormals;
    }
}

bool anyNormalInvalid(const Mesh& mesh)
{
    return std::any_of(mesh.vertices.begin(), mesh.vertices.end(),
                       [](const Vertex& v) { return normalState(v.normal) != NormalState::Valid; });
}

} // namespace

RepairReport repairMesh(Mesh& mesh, const RepairOptions& options)
{
    checkTriangleList(mesh);
    RepairReport report;
    dropBadTriangles(mesh, options.degenerateAreaRel, report);
    removeUnusedVertices(mesh, report);
    if (options.weld) {
        weldVertices(mesh, options.weldDistanceRel, report);
        // Welding can collapse a thin triangle's corners onto each other.
        dropBadTriangles(mesh, options.degenerateAreaRel, report);
        removeUnusedVertices(mesh, report);
    }
    normalizeNormals(mesh, report);
    const bool needNormals = anyNormalInvalid(mesh);
    if (needNormals || options.analyzeTopology) {
        const Topology topo = buildTopology(mesh, report);
        if (needNormals) fillNormals(mesh, topo, report);
    }
    mesh.computeBounds();
    return report;
}

} // namespace penumbra::scene
