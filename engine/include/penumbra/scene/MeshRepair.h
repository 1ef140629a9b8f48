#pragma once
// Cleans a mesh at load so that every later stage (bounds, BVH, shadow maps, ray casts)
// sees finite, non-degenerate triangles with usable normals, and says what it changed.
// Sizes are relative to the mesh: d is the diagonal of the bounding box of the mesh's
// finite vertices, so one setting suits a 1 cm screw and a 1 km terrain alike.
#include "penumbra/scene/Scene.h"

#include <cstdint>

namespace penumbra::scene {

struct RepairOptions {
    // A triangle whose area is at most degenerateAreaRel · d² is dropped: with the
    // default 1e-12 a 1 m mesh loses triangles under 1 µm², i.e. slivers thinner than
    // float positions can resolve (a float has 24 bits: 6e-8 of the coordinates).
    double degenerateAreaRel = 1e-12;
    // Welding merges vertices closer than weldDistanceRel · d whose uv and normal also
    // agree (so texture seams and hard edges stay split). Off by default: glTF
    // exporters write shared vertices already, and a weld changes the vertex count.
    bool weld = false;
    double weldDistanceRel = 1e-6;
    // Build the half-edge topology (OpenMesh) even when no normal needs generating,
    // to count open and non-manifold edges (`penumbra validate` asks for it).
    bool analyzeTopology = false;
};

struct RepairReport {
    uint32_t nonFiniteTriangles = 0;   // dropped: a corner at NaN or ±Inf
    uint32_t degenerateTriangles = 0;  // dropped: area under the threshold (repeated corners too)
    uint32_t unusedVertices = 0;       // removed: no triangle left uses them
    uint32_t weldedVertices = 0;       // merged into an equal vertex nearby
    uint32_t generatedNormals = 0;     // had none (a zero normal means "missing"): area-weighted normal
    uint32_t replacedNormals = 0;      // NaN or ±Inf normal replaced by the area-weighted one
    uint32_t renormalizedNormals = 0;  // finite but not unit length (off by more than 1e-3): normalized
    // Half-edge topology, when it was built (normals generated or analyzeTopology):
    bool topologyAnalyzed = false;
    uint32_t boundaryEdges = 0;         // edges with one triangle: the surface is open there
    uint32_t nonManifoldTriangles = 0;  // triangles on an edge that already has two, or flipped against
                                        // their neighbours: kept, but outside the manifold surface

    uint32_t droppedTriangles() const { return nonFiniteTriangles + degenerateTriangles; }
    bool changedMesh() const
    {
        return droppedTriangles() + unusedVertices + weldedVertices + generatedNormals + replacedNormals +
                   renormalizedNormals >
               0;
    }
};

// Repairs `mesh` in place (indices must be a triangle list within the vertices; throws
// Error otherwise) and recomputes its bounds. A mesh may end up with no triangles.
RepairReport repairMesh(Mesh& mesh, const RepairOptions& options = {});

} // namespace penumbra::scene
