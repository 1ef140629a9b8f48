#pragma once
// Writes a Scene as glTF 2.0 with tinygltf, so that generated scenes can be viewed,
// checked and shared with other tools.
#include "penumbra/scene/Scene.h"

#include <filesystem>

namespace penumbra::scene {

// `path` ending in .gltf writes JSON plus `<stem>.bin` beside it; .glb writes one
// binary file (either case). The glTF has one node per scene node, with its hierarchy,
// names and local transform (translation/scale when the matrix is just that, else the
// matrix); one mesh with one triangle primitive per scene mesh (POSITION with min/max,
// NORMAL, TEXCOORD_0, u32 indices), referenced by every node that instances it (a node
// with several instances gets one child node per extra instance); the materials
// (baseColorFactor, base colour texture as a PNG in the buffer, alphaMode, alphaCutoff,
// doubleSided) and one scene whose roots are the graph's roots.
// Every file is written to a temporary name beside it and renamed into place once all
// are complete, so a failure never leaves a partial file nor clobbers an existing one.
// Throws Error naming the path for a bad path or extension, or a mesh that cannot be
// written (no triangles, an index past its vertices).
void writeGltf(const Scene& scene, const std::filesystem::path& path);

// Throws Error naming `path` unless it ends in .gltf or .glb and its folder is
// writable: what writeGltf() checks first, for callers that want to fail before
// building a scene.
void checkGltfOutput(const std::filesystem::path& path);

} // namespace penumbra::scene
