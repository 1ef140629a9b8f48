#pragma once
// The scene as the renderer sees it: meshes (shared geometry), instances (a mesh under a
// transform, with a material), a camera and lights. glTF loading, the scene graph and
// the BVH arrive with the scenes issue; the generators here make the foundation's test
// scenes from a seed.
#include <glm/glm.hpp>

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace penumbra::scene {

struct Vertex {
    glm::vec3 position;
    glm::vec3 normal;
};

struct Mesh {
    std::string name;
    std::vector<Vertex> vertices;
    std::vector<uint32_t> indices;  // triangle list
};

struct Aabb {
    glm::vec3 min{std::numeric_limits<float>::max()};
    glm::vec3 max{-std::numeric_limits<float>::max()};
    void extend(const glm::vec3& p);
    void extend(const Aabb& box);
    bool empty() const { return min.x > max.x; }
    glm::vec3 center() const { return 0.5f * (min + max); }
    float radius() const { return 0.5f * glm::length(max - min); }
};

struct Material {
    glm::vec4 baseColor{0.8f, 0.8f, 0.8f, 1.0f};
};

struct Instance {
    uint32_t mesh = 0;
    glm::mat4 transform{1.0f};
    Material material;
};

struct Camera {
    glm::vec3 position{0.0f, 2.0f, 5.0f};
    glm::vec3 target{0.0f};
    glm::vec3 up{0.0f, 1.0f, 0.0f};
    float fovYDeg = 45.0f;
    float nearWorld = 0.05f;
};

enum class LightType { Spot };

struct Light {
    LightType type = LightType::Spot;
    glm::vec3 position{0.0f, 10.0f, 0.0f};
    glm::vec3 direction{0.0f, -1.0f, 0.0f};  // unit, where the spot points
    float outerConeDeg = 40.0f;              // half-angle where the light reaches zero
    float innerConeDeg = 32.0f;              // half-angle of full intensity
    float intensity = 300.0f;                // radiant intensity on the axis (W/sr)
    glm::vec3 color{1.0f};
};

class Scene {
public:
    std::vector<Mesh> meshes;
    std::vector<Instance> instances;

    Aabb meshBounds(uint32_t mesh) const;
    Aabb instanceBounds(const Instance& instance) const;
    Aabb bounds() const;
    size_t triangleCount() const;
};

// The foundation's default scene: a ground plane, a grid of boxes of varied heights and
// a sphere, deterministic for a seed.
struct BoxGridParams {
    uint32_t columns = 5;
    uint32_t rows = 5;
    float boxSize = 1.2f;         // footprint edge (world units)
    float spacing = 3.0f;         // centre-to-centre distance
    float minHeight = 0.8f;
    float maxHeight = 2.6f;
    float sphereRadius = 1.6f;
    uint32_t sphereSegments = 96;  // around the equator; rings = segments / 2
    float planeSize = 40.0f;
    uint32_t seed = 1;
};

Scene generateBoxGrid(const BoxGridParams& params);

Mesh makeBox(const std::string& name);                       // unit cube [-0.5, 0.5]^3
Mesh makePlane(const std::string& name);                     // unit square in XZ, normal +Y
Mesh makeSphere(const std::string& name, uint32_t segments);  // unit radius

} // namespace penumbra::scene
