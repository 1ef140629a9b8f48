#include "penumbra/scene/Scene.h"

#include "penumbra/core/Error.h"

#include <fmt/format.h>
#include <glm/gtc/constants.hpp>

#include <algorithm>

namespace penumbra::scene {

const char* lightTypeName(LightType type)
{
    switch (type) {
    case LightType::Directional: return "directional";
    case LightType::Spot: return "spot";
    case LightType::Point: return "point";
    case LightType::Rect: return "rect";
    case LightType::Disk: return "disk";
    }
    return "unknown";
}

void Aabb::extend(const glm::vec3& p)
{
    min = glm::min(min, p);
    max = glm::max(max, p);
}

void Aabb::extend(const Aabb& box)
{
    if (!box.empty()) {
        extend(box.min);
        extend(box.max);
    }
}

float Aabb::surfaceArea() const
{
    const glm::vec3 e = extent();
    return 2.0f * (e.x * e.y + e.y * e.z + e.z * e.x);
}

Aabb Aabb::transformed(const glm::mat4& m) const
{
    Aabb out;
    if (empty()) return out;
    for (int c = 0; c < 8; ++c) out.extend(glm::vec3(m * glm::vec4(corner(c), 1.0f)));
    return out;
}

void Mesh::computeBounds()
{
    bounds = Aabb{};
    for (const Vertex& v : vertices) bounds.extend(v.position);
}

uint32_t Scene::addInstance(uint32_t mesh, uint32_t node)
{
    if (mesh >= meshes.size() || node >= graph.size()) {
        throw Error(fmt::format("scene: instance of mesh {} under node {}: no such mesh or node", mesh, node));
    }
    instances.push_back({mesh, node, meshes[mesh].bounds.transformed(graph.world(node))});
    return static_cast<uint32_t>(instances.size() - 1);
}

std::vector<uint32_t> Scene::updateTransforms()
{
    std::vector<uint32_t> changed;
    const std::vector<uint32_t> moved = graph.update();
    if (moved.empty()) return changed;
    std::vector<uint8_t> nodeMoved(graph.size(), 0);
    for (uint32_t n : moved) nodeMoved[n] = 1;
    for (uint32_t i = 0; i < instances.size(); ++i) {
        Instance& inst = instances[i];
        if (!nodeMoved[inst.node]) continue;
        inst.worldBounds = meshes[inst.mesh].bounds.transformed(graph.world(inst.node));
        changed.push_back(i);
    }
    return changed;
}

Aabb Scene::bounds() const
{
    Aabb box;
    for (const Instance& instance : instances) box.extend(instance.worldBounds);
    return box;
}

size_t Scene::triangleCount() const
{
    size_t count = 0;
    for (const Instance& instance : instances) count += meshes.at(instance.mesh).indices.size() / 3;
    return count;
}

size_t Scene::materialsUsed() const
{
    std::vector<uint8_t> used(materials.size(), 0);
    for (const Mesh& mesh : meshes) used.at(mesh.material) = 1;
    return size_t(std::count(used.begin(), used.end(), uint8_t(1)));
}

uint32_t appendUnderRoot(Scene& scene, Scene part, std::string name, const glm::mat4& local)
{
    const auto meshBase = uint32_t(scene.meshes.size());
    const auto materialBase = uint32_t(scene.materials.size());
    const auto textureBase = int32_t(scene.textures.size());
    for (Material& material : part.materials) {
        if (material.baseColorTexture != kNoTexture) material.baseColorTexture += textureBase;
        scene.materials.push_back(std::move(material));
    }
    for (Texture& texture : part.textures) scene.textures.push_back(std::move(texture));
    for (Mesh& mesh : part.meshes) {
        mesh.material += materialBase;
        scene.meshes.push_back(std::move(mesh));
    }
    const uint32_t root = scene.graph.addNode(std::move(name), kNoParent, local);
    const uint32_t nodeBase = root + 1;
    for (uint32_t n = 0; n < part.graph.size(); ++n) {
        const Node& node = part.graph.node(n);
        // Parents come first in the part, so they do in the scene too.
        const int32_t parent = node.parent == kNoParent ? int32_t(root) : node.parent + int32_t(nodeBase);
        scene.graph.addNode(node.name, parent, node.local);
    }
    for (const Instance& instance : part.instances) scene.addInstance(instance.mesh + meshBase, instance.node + nodeBase);
    for (NodeAnimation& animation : part.animations) {
        for (NodeChannel& channel : animation.channels) channel.node += nodeBase;
        for (NodeRestPose& rest : animation.rest) rest.node += nodeBase;
        scene.animations.push_back(std::move(animation));
    }
    return root;
}

Mesh makeBox(const std::string& name)
{
    Mesh mesh{name, {}, {}};
    // Six faces, each with its own four vertices so that normals are flat.
    const glm::vec3 normals[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    for (const glm::vec3& n : normals) {
        const glm::vec3 t = std::abs(n.y) > 0.5f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
        const glm::vec3 b = glm::cross(n, t);
        const auto base = static_cast<uint32_t>(mesh.vertices.size());
        const glm::vec2 corners[4] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
        for (const glm::vec2& c : corners) {
            mesh.vertices.push_back({0.5f * (n + c.x * t + c.y * b), n, 0.5f * (c + 1.0f)});
        }
        // t × b = n, so the corners run counter-clockwise seen from outside.
        mesh.indices.insert(mesh.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
    }
    return mesh;
}

Mesh makePlane(const std::string& name)
{
    Mesh mesh{name, {}, {}};
    const glm::vec3 n{0, 1, 0};
    mesh.vertices = {{{-0.5f, 0, -0.5f}, n, {0, 0}}, {{0.5f, 0, -0.5f}, n, {1, 0}}, {{0.5f, 0, 0.5f}, n, {1, 1}}, {{-0.5f, 0, 0.5f}, n, {0, 1}}};
    // Counter-clockwise seen from above (+Y).
    mesh.indices = {0, 2, 1, 0, 3, 2};
    return mesh;
}

Mesh makeSphere(const std::string& name, uint32_t segments)
{
    if (segments < 3) {
        throw Error(fmt::format("sphere '{}': {} segments, need at least 3", name, segments));
    }
    Mesh mesh{name, {}, {}};
    const uint32_t rings = std::max(2u, segments / 2);
    for (uint32_t r = 0; r <= rings; ++r) {
        const float theta = glm::pi<float>() * float(r) / float(rings);
        for (uint32_t s = 0; s <= segments; ++s) {
            const float phi = glm::two_pi<float>() * float(s) / float(segments);
            const glm::vec3 p{std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi)};
            mesh.vertices.push_back({p, p, {float(s) / float(segments), float(r) / float(rings)}});
        }
    }
    const uint32_t stride = segments + 1;
    for (uint32_t r = 0; r < rings; ++r) {
        for (uint32_t s = 0; s < segments; ++s) {
            const uint32_t a = r * stride + s, b = a + stride, c = b + 1, d = a + 1;
            // Skip the zero-area triangles at the poles.
            if (r != 0) mesh.indices.insert(mesh.indices.end(), {a, d, b});
            if (r != rings - 1) mesh.indices.insert(mesh.indices.end(), {d, c, b});
        }
    }
    return mesh;
}

} // namespace penumbra::scene
