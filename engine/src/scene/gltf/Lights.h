#pragma once
// KHR_lights_punctual: a node's light -> a GltfLight in world space.
#include "scene/gltf/Document.h"

#include <optional>

namespace penumbra::scene::gltf {

// The light glTF node `node` carries, placed by its world transform (glTF lights shine
// along the node's -Z), or nullopt when it carries none.
std::optional<GltfLight> lightOfNode(const Document& doc, int node, uint32_t graphNode, const glm::mat4& world);

} // namespace penumbra::scene::gltf
