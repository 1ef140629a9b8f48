#include "penumbra/scene/SceneGraph.h"

#include "penumbra/core/Error.h"

#include <fmt/format.h>

namespace penumbra::scene {

uint32_t SceneGraph::addNode(std::string name, int32_t parent, const glm::mat4& local)
{
    if (parent != kNoParent && (parent < 0 || size_t(parent) >= nodes_.size())) {
        throw Error(fmt::format("scene graph: node '{}' names parent {}, which does not exist (yet)", name, parent));
    }
    nodes_.push_back({std::move(name), parent, local});
    world_.push_back(parent == kNoParent ? local : world_[size_t(parent)] * local);
    dirty_.push_back(0);
    return static_cast<uint32_t>(nodes_.size() - 1);
}

void SceneGraph::setLocal(uint32_t node, const glm::mat4& local)
{
    nodes_.at(node).local = local;
    dirty_[node] = 1;
    anyDirty_ = true;
}

std::vector<uint32_t> SceneGraph::update()
{
    std::vector<uint32_t> moved;
    if (!anyDirty_) return moved;
    for (size_t i = 0; i < nodes_.size(); ++i) {
        const int32_t parent = nodes_[i].parent;
        // Parents come first, so the parent's flag is final here: a dirty ancestor makes
        // the whole subtree dirty in this one pass.
        if (parent != kNoParent && dirty_[size_t(parent)]) dirty_[i] = 1;
        if (!dirty_[i]) continue;
        world_[i] = parent == kNoParent ? nodes_[i].local : world_[size_t(parent)] * nodes_[i].local;
        moved.push_back(static_cast<uint32_t>(i));
    }
    std::fill(dirty_.begin(), dirty_.end(), 0);
    anyDirty_ = false;
    return moved;
}

} // namespace penumbra::scene
