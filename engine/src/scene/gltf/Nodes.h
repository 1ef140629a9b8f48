#pragma once
// The glTF node forest -> SceneGraph. glTF lists nodes in any order and only says who
// the children are; the graph needs parents first. Nodes with two parents and cycles
// are refused by name (following parents from any node either reaches a root or
// loops), and only the loaded scene's trees are inserted, depth-first.
#include "scene/gltf/Document.h"

#include <cstdint>
#include <vector>

namespace penumbra::scene::gltf {

struct NodeMap {
    std::vector<int32_t> graphNode;  // glTF node -> scene graph node, -1 outside the loaded scene
    std::vector<int> loaded;         // the glTF nodes inserted, parents first
};

// Inserts the default scene's nodes (every root node when the file names no default
// scene) into `graph` with their local transforms (matrix, or translation · rotation · scale).
NodeMap buildSceneGraph(const Document& doc, SceneGraph& graph);

} // namespace penumbra::scene::gltf
