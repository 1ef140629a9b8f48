#pragma once
// The scene as the engine sees it: meshes (one glTF primitive each: geometry plus a
// material), materials and textures, a node hierarchy (SceneGraph), and instances (a
// mesh under a node, so one mesh under many nodes is instancing). Cameras and lights
// with the config; glTF files and the procedural generators fill this same structure.
#include "penumbra/scene/NodeAnimation.h"
#include "penumbra/scene/SceneGraph.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace penumbra::scene {

struct Vertex {
    glm::vec3 position;
    glm::vec3 normal;
    glm::vec2 uv;
};

struct Aabb {
    glm::vec3 min{std::numeric_limits<float>::max()};
    glm::vec3 max{-std::numeric_limits<float>::max()};
    void extend(const glm::vec3& p);
    void extend(const Aabb& box);
    bool empty() const { return min.x > max.x || min.y > max.y || min.z > max.z; }
    glm::vec3 center() const { return 0.5f * (min + max); }
    glm::vec3 extent() const { return empty() ? glm::vec3(0.0f) : max - min; }
    float radius() const { return empty() ? 0.0f : 0.5f * glm::length(max - min); }
    float surfaceArea() const;
    // Corner `i` of 8: bit 0 picks max.x, bit 1 max.y, bit 2 max.z.
    glm::vec3 corner(int i) const
    {
        return {(i & 1) ? max.x : min.x, (i & 2) ? max.y : min.y, (i & 4) ? max.z : min.z};
    }
    // The box of this box's eight corners under `m`.
    Aabb transformed(const glm::mat4& m) const;
};

enum class AlphaMode { Opaque, Mask, Blend };

// An RGBA8 image, base colour in sRGB encoding (glTF's convention).
struct Texture {
    std::string name;
    uint32_t width = 0;
    uint32_t height = 0;
    std::vector<uint8_t> rgba;
};

inline constexpr int32_t kNoTexture = -1;

struct Material {
    std::string name = "default";
    glm::vec4 baseColor{0.8f, 0.8f, 0.8f, 1.0f};  // linear rgb, a = alpha
    int32_t baseColorTexture = kNoTexture;          // index into Scene::textures
    AlphaMode alphaMode = AlphaMode::Opaque;
    float alphaCutoff = 0.5f;  // AlphaMode::Mask: alpha below it is a hole
    bool doubleSided = false;
};

struct Mesh {
    std::string name;
    std::vector<Vertex> vertices;
    std::vector<uint32_t> indices;  // triangle list
    uint32_t material = 0;          // index into Scene::materials
    Aabb bounds;                    // object space; computeBounds() fills it
    void computeBounds();
};

struct Instance {
    uint32_t mesh = 0;
    uint32_t node = 0;  // its world transform is graph.world(node)
    Aabb worldBounds;   // kept current by Scene::updateTransforms()
};

struct Camera {
    glm::vec3 position{0.0f, 2.0f, 5.0f};
    glm::vec3 target{0.0f};
    glm::vec3 up{0.0f, 1.0f, 0.0f};
    float fovYDeg = 45.0f;
    float nearWorld = 0.05f;
};

// Light models. Spot lights are points; point lights are points or, with a radius,
// spheres; directional lights may have an angular diameter (the sun: 0.53 degrees);
// rectangle and disk lights have a world-space size.
// Hard-shadow techniques treat every light as its centre point (or its direction);
// soft-shadow techniques use the extent.
enum class LightType { Directional, Spot, Point, Rect, Disk };

const char* lightTypeName(LightType type);

struct Light {
    LightType type = LightType::Spot;
    glm::vec3 position{0.0f, 10.0f, 0.0f};   // centre (all but directional)
    // Unit vector. Directional: the direction the light travels; spot: the cone axis;
    // rect and disk: the emitting side's normal (they emit into that hemisphere only).
    glm::vec3 direction{0.0f, -1.0f, 0.0f};
    glm::vec3 tangent{1.0f, 0.0f, 0.0f};     // rect: the width axis (unit, normal to direction)
    float outerConeDeg = 40.0f;              // spot: half-angle where the light reaches zero
    float innerConeDeg = 32.0f;              // spot: half-angle of full intensity
    float angularDiameterDeg = 0.0f;         // directional: apparent size of the source
    glm::vec2 sizeWorld{0.0f};               // rect: width, height
    float radiusWorld = 0.0f;                // disk: radius; point: sphere radius (0: a point)
    // Directional: irradiance on a surface facing the light (W/m²). Others: radiant
    // intensity along the axis / normal (W/sr).
    float intensity = 300.0f;
    glm::vec3 color{1.0f};

    bool operator==(const Light&) const = default;
};

class Scene {
public:
    std::vector<Mesh> meshes;
    std::vector<Material> materials{Material{}};  // index 0: the default material
    std::vector<Texture> textures;
    SceneGraph graph;
    std::vector<Instance> instances;
    // A glTF file's animations (clips of node channels), at rest until one is played.
    std::vector<NodeAnimation> animations;

    // Adds `mesh` under `node`; the mesh's bounds must be computed.
    uint32_t addInstance(uint32_t mesh, uint32_t node);
    const glm::mat4& instanceTransform(const Instance& instance) const { return graph.world(instance.node); }

    // Propagates moved nodes to world transforms and instance world bounds; returns the
    // instances whose bounds changed (ascending), for a BVH refit.
    std::vector<uint32_t> updateTransforms();

    Aabb bounds() const;
    size_t triangleCount() const;
    // The materials that meshes use (the default at index 0 only where a mesh has no
    // material of its own): what a file or a generator brought, not the slots held.
    size_t materialsUsed() const;
};

// Moves `part` into `scene` below a new root node `name` with local transform `local`:
// its meshes, materials, textures, nodes (its roots become the new node's children),
// instances and animations, each index shifted past what `scene` held, so that several
// files and generators make one scene with one node per part to place it. Returns the
// new root node; the part's node i is node root + 1 + i.
uint32_t appendUnderRoot(Scene& scene, Scene part, std::string name, const glm::mat4& local);

// Mesh builders for the procedural scenes (Generators.h).
Mesh makeBox(const std::string& name);                       // unit cube [-0.5, 0.5]^3
Mesh makePlane(const std::string& name);                     // unit square in XZ, normal +Y
Mesh makeSphere(const std::string& name, uint32_t segments);  // unit radius

} // namespace penumbra::scene
