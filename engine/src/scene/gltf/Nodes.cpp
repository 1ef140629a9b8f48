#include "scene/gltf/Nodes.h"

#include "penumbra/core/ShortText.h"

#include <fmt/format.h>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>

#include <algorithm>
#include <cmath>

namespace penumbra::scene::gltf {
namespace {

std::string nodePath(size_t node) { return fmt::format("/nodes/{}", node); }

std::string nodeLabel(const tinygltf::Model& model, size_t node)
{
    const std::string& name = model.nodes[node].name;
    return name.empty() ? fmt::format("node {}", node) : fmt::format("node {} '{}'", node, core::shortText(name));
}

// parent[i]: the node listing i among its children, or -1.
std::vector<int> parentsOf(const Document& doc)
{
    const std::vector<tinygltf::Node>& nodes = doc.model.nodes;
    std::vector<int> parent(nodes.size(), -1);
    for (size_t i = 0; i < nodes.size(); ++i) {
        for (size_t k = 0; k < nodes[i].children.size(); ++k) {
            const int child = nodes[i].children[k];
            if (child < 0 || size_t(child) >= nodes.size()) {
                doc.fail(fmt::format("/nodes/{}/children/{}", i, k),
                         fmt::format("node {} does not exist ({} nodes)", child, nodes.size()));
            }
            if (size_t(child) == i) doc.fail(nodePath(i), fmt::format("{} is its own child", nodeLabel(doc.model, i)));
            if (parent[size_t(child)] >= 0) {
                doc.fail(nodePath(size_t(child)), fmt::format("{} has two parents: nodes {} and {}",
                                                              nodeLabel(doc.model, size_t(child)), parent[size_t(child)], i));
            }
            parent[size_t(child)] = int(i);
        }
    }
    return parent;
}

void rejectCycles(const Document& doc, const std::vector<int>& parent)
{
    enum : uint8_t { Unvisited, OnWalk, ReachesRoot };
    std::vector<uint8_t> state(parent.size(), Unvisited);
    std::vector<int> walk;
    for (size_t start = 0; start < parent.size(); ++start) {
        walk.clear();
        int v = int(start);
        while (v >= 0 && state[size_t(v)] == Unvisited) {
            state[size_t(v)] = OnWalk;
            walk.push_back(v);
            v = parent[size_t(v)];
        }
        if (v >= 0 && state[size_t(v)] == OnWalk) {
            // v is on a loop of parents; list it parent-to-child.
            std::vector<int> loop{v};
            for (int p = parent[size_t(v)]; p != v; p = parent[size_t(p)]) loop.push_back(p);
            loop.push_back(v);
            std::reverse(loop.begin(), loop.end());
            std::string chain;
            for (int n : loop) chain += (chain.empty() ? "" : " -> ") + nodeLabel(doc.model, size_t(n));
            doc.fail(nodePath(size_t(loop.front())), fmt::format("nodes form a cycle, each the parent of the next: {}", chain));
        }
        for (int w : walk) state[size_t(w)] = ReachesRoot;
    }
}

std::vector<int> sceneRoots(const Document& doc, const std::vector<int>& parent)
{
    const tinygltf::Model& model = doc.model;
    std::vector<int> roots;
    if (model.defaultScene < 0) {
        for (size_t i = 0; i < parent.size(); ++i) {
            if (parent[i] < 0) roots.push_back(int(i));
        }
        if (!model.scenes.empty()) doc.note("/scene", "the file names no default scene; every root node is loaded");
        return roots;
    }
    if (size_t(model.defaultScene) >= model.scenes.size()) {
        doc.fail("/scene", fmt::format("scene {} does not exist ({} scenes)", model.defaultScene, model.scenes.size()));
    }
    const std::vector<int>& listed = model.scenes[size_t(model.defaultScene)].nodes;
    std::vector<uint8_t> seen(parent.size(), 0);
    for (size_t k = 0; k < listed.size(); ++k) {
        const std::string path = fmt::format("/scenes/{}/nodes/{}", model.defaultScene, k);
        const int root = listed[k];
        if (root < 0 || size_t(root) >= parent.size()) {
            doc.fail(path, fmt::format("node {} does not exist ({} nodes)", root, parent.size()));
        }
        if (parent[size_t(root)] >= 0) {
            doc.fail(path, fmt::format("{} is a child of node {}; a scene lists root nodes only",
                                       nodeLabel(model, size_t(root)), parent[size_t(root)]));
        }
        if (seen[size_t(root)]) doc.fail(path, fmt::format("{} is listed twice", nodeLabel(model, size_t(root))));
        seen[size_t(root)] = 1;
        roots.push_back(root);
    }
    return roots;
}

bool allFinite(const std::vector<double>& values)
{
    return std::all_of(values.begin(), values.end(), [](double x) { return std::isfinite(x); });
}

glm::mat4 localTransform(const Document& doc, size_t index)
{
    const tinygltf::Node& node = doc.model.nodes[index];
    const std::string path = nodePath(index);
    auto check = [&](const std::vector<double>& values, size_t size, const char* name) {
        if ((!values.empty() && values.size() != size) || !allFinite(values)) {
            doc.fail(path + "/" + name, fmt::format("must be {} finite numbers", size));
        }
    };
    check(node.matrix, 16, "matrix");
    check(node.translation, 3, "translation");
    check(node.rotation, 4, "rotation");
    check(node.scale, 3, "scale");
    if (!node.matrix.empty()) {
        glm::mat4 m;
        for (int k = 0; k < 16; ++k) m[k / 4][k % 4] = float(node.matrix[size_t(k)]);  // column-major, as glm
        return m;
    }
    glm::mat4 m(1.0f);
    if (!node.translation.empty()) {
        m = glm::translate(m, glm::vec3(node.translation[0], node.translation[1], node.translation[2]));
    }
    if (!node.rotation.empty()) {
        // glTF stores (x, y, z, w); glm::quat takes w first.
        const glm::quat q(float(node.rotation[3]), float(node.rotation[0]), float(node.rotation[1]), float(node.rotation[2]));
        const float length = glm::length(q);
        if (!(length > 1e-6f)) doc.fail(path + "/rotation", "is a zero quaternion");
        m *= glm::mat4_cast(q / length);
    }
    if (!node.scale.empty()) m = glm::scale(m, glm::vec3(node.scale[0], node.scale[1], node.scale[2]));
    return m;
}

} // namespace

NodeMap buildSceneGraph(const Document& doc, SceneGraph& graph)
{
    const std::vector<int> parent = parentsOf(doc);
    rejectCycles(doc, parent);
    NodeMap map;
    map.graphNode.assign(parent.size(), -1);
    // Depth-first with an explicit stack: a chain of 100k nodes must not overflow the call stack.
    std::vector<std::pair<int, int32_t>> stack;  // glTF node, its parent's graph node
    const std::vector<int> roots = sceneRoots(doc, parent);
    for (auto it = roots.rbegin(); it != roots.rend(); ++it) stack.emplace_back(*it, kNoParent);
    while (!stack.empty()) {
        const auto [index, graphParent] = stack.back();
        stack.pop_back();
        const tinygltf::Node& node = doc.model.nodes[size_t(index)];
        const std::string name = node.name.empty() ? fmt::format("node{}", index) : node.name;
        const uint32_t graphNode = graph.addNode(name, graphParent, localTransform(doc, size_t(index)));
        map.graphNode[size_t(index)] = int32_t(graphNode);
        map.loaded.push_back(index);
        for (auto child = node.children.rbegin(); child != node.children.rend(); ++child) {
            stack.emplace_back(*child, int32_t(graphNode));
        }
    }
    return map;
}

} // namespace penumbra::scene::gltf
