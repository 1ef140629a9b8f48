#pragma once
// Node hierarchy with local and world transforms. Nodes are stored parents-first (a
// node's parent has a smaller index), so one pass in index order recomputes every dirty
// world transform, and a moved node dirties its whole subtree on the way.
#include <glm/glm.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace penumbra::scene {

inline constexpr int32_t kNoParent = -1;

struct Node {
    std::string name;
    int32_t parent = kNoParent;
    glm::mat4 local{1.0f};
};

class SceneGraph {
public:
    // Adds a node under `parent` (kNoParent for a root). Throws Error if the parent does
    // not exist yet: parents come first, which also makes cycles impossible.
    uint32_t addNode(std::string name, int32_t parent, const glm::mat4& local);

    void setLocal(uint32_t node, const glm::mat4& local);
    const glm::mat4& local(uint32_t node) const { return nodes_.at(node).local; }
    const Node& node(uint32_t node) const { return nodes_.at(node); }
    size_t size() const { return nodes_.size(); }

    // World transform as of the last update().
    const glm::mat4& world(uint32_t node) const { return world_.at(node); }

    // Recomputes the world transform of every node that moved or whose ancestor moved;
    // returns those nodes (ascending). Cheap when nothing moved.
    std::vector<uint32_t> update();
    bool dirty() const { return anyDirty_; }

private:
    std::vector<Node> nodes_;
    std::vector<glm::mat4> world_;
    std::vector<uint8_t> dirty_;
    bool anyDirty_ = false;
};

} // namespace penumbra::scene
