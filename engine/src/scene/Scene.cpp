#include "penumbra/scene/Scene.h"

#include "penumbra/core/Error.h"

#include <fmt/format.h>
#include <glm/gtc/constants.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <random>

namespace penumbra::scene {

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

Aabb Scene::meshBounds(uint32_t mesh) const
{
    Aabb box;
    for (const Vertex& v : meshes.at(mesh).vertices) box.extend(v.position);
    return box;
}

Aabb Scene::instanceBounds(const Instance& instance) const
{
    const Aabb local = meshBounds(instance.mesh);
    Aabb world;
    if (local.empty()) return world;
    for (int corner = 0; corner < 8; ++corner) {
        const glm::vec3 p{corner & 1 ? local.max.x : local.min.x, corner & 2 ? local.max.y : local.min.y,
                          corner & 4 ? local.max.z : local.min.z};
        world.extend(glm::vec3(instance.transform * glm::vec4(p, 1.0f)));
    }
    return world;
}

Aabb Scene::bounds() const
{
    Aabb box;
    for (const Instance& instance : instances) box.extend(instanceBounds(instance));
    return box;
}

size_t Scene::triangleCount() const
{
    size_t count = 0;
    for (const Instance& instance : instances) count += meshes.at(instance.mesh).indices.size() / 3;
    return count;
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
            mesh.vertices.push_back({0.5f * (n + c.x * t + c.y * b), n});
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
    mesh.vertices = {{{-0.5f, 0, -0.5f}, n}, {{0.5f, 0, -0.5f}, n}, {{0.5f, 0, 0.5f}, n}, {{-0.5f, 0, 0.5f}, n}};
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
            mesh.vertices.push_back({p, p});
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

Scene generateBoxGrid(const BoxGridParams& p)
{
    Scene scene;
    scene.meshes.push_back(makePlane("ground"));
    scene.meshes.push_back(makeBox("box"));
    scene.meshes.push_back(makeSphere("sphere", p.sphereSegments));

    Instance ground{0, glm::scale(glm::mat4(1.0f), glm::vec3(p.planeSize, 1.0f, p.planeSize)), {}};
    ground.material.baseColor = {0.75f, 0.75f, 0.72f, 1.0f};
    scene.instances.push_back(ground);

    std::mt19937 rng(p.seed);
    std::uniform_real_distribution<float> height(p.minHeight, p.maxHeight);
    std::uniform_real_distribution<float> hue(0.0f, 1.0f);
    const float x0 = -0.5f * p.spacing * float(p.columns - 1);
    const float z0 = -0.5f * p.spacing * float(p.rows - 1);
    for (uint32_t row = 0; row < p.rows; ++row) {
        for (uint32_t col = 0; col < p.columns; ++col) {
            const float h = height(rng);
            const glm::vec3 centre{x0 + p.spacing * float(col), 0.5f * h, z0 + p.spacing * float(row)};
            Instance box{1, glm::scale(glm::translate(glm::mat4(1.0f), centre), glm::vec3(p.boxSize, h, p.boxSize)), {}};
            const float t = hue(rng);
            box.material.baseColor = {0.55f + 0.35f * t, 0.45f + 0.2f * (1.0f - t), 0.35f + 0.3f * t, 1.0f};
            scene.instances.push_back(box);
        }
    }
    // The sphere floats beside the grid so that its shadow falls on the ground, apart
    // from the boxes' shadows.
    const glm::vec3 sphereCentre{x0 + p.spacing * float(p.columns) + p.sphereRadius, 1.5f * p.sphereRadius,
                                 0.0f};
    Instance sphere{2, glm::scale(glm::translate(glm::mat4(1.0f), sphereCentre), glm::vec3(p.sphereRadius)), {}};
    sphere.material.baseColor = {0.3f, 0.45f, 0.8f, 1.0f};
    scene.instances.push_back(sphere);
    return scene;
}

} // namespace penumbra::scene
