#pragma once
// One glTF primitive -> one triangle-list Mesh (positions, normals, TEXCOORD_0).
#include "scene/gltf/Document.h"

#include <cstdint>
#include <optional>

namespace penumbra::scene::gltf {

// What the file may still allocate: GltfLoadOptions' limits minus what is loaded.
struct GeometryBudget {
    uint64_t vertices = 0;
    uint64_t triangles = 0;
};

// TRIANGLES, TRIANGLE_STRIP and TRIANGLE_FAN become a triangle list; points and lines
// are refused with a warning (nullopt). Where the file has no NORMAL the normals are
// zero, which repairMesh() reads as missing. Takes the mesh's size from `budget`.
std::optional<Mesh> convertPrimitive(const Document& doc, int mesh, int primitive, GeometryBudget& budget);

} // namespace penumbra::scene::gltf
