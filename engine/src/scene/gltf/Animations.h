#pragma once
// glTF animations -> scene::NodeAnimation clips. An accessor of the wrong type or out of
// range refuses the file, as for geometry; a channel that cannot play (times that do not
// increase, values that are not finite or do not match the keys, a node outside the loaded
// scene or given by a matrix, morph target weights) is left out with a warning that names
// it, and the clip plays the rest.
#include "penumbra/scene/NodeAnimation.h"
#include "scene/gltf/Document.h"
#include "scene/gltf/Nodes.h"

#include <vector>

namespace penumbra::scene::gltf {

std::vector<NodeAnimation> loadAnimations(const Document& doc, const NodeMap& nodes);

} // namespace penumbra::scene::gltf
