#pragma once
// Brute-force ray casting over a scene's world-space triangles (with a per-instance box
// test first), in double precision: the independent geometric truth that rendering
// tests compare visibility images against.
#include "penumbra/scene/Scene.h"

#include <glm/glm.hpp>

#include <vector>

namespace penumbra::test {

class RayCaster {
public:
    explicit RayCaster(const scene::Scene& scene);
    // True if a triangle intersects the open segment from `from` to `to`.
    bool segmentBlocked(const glm::dvec3& from, const glm::dvec3& to) const;
    // Distance along the unit direction `dir` from `origin` to the first triangle hit,
    // or +inf when the ray hits nothing.
    double closestHit(const glm::dvec3& origin, const glm::dvec3& dir) const;

private:
    struct InstanceTriangles {
        glm::dvec3 boxMin, boxMax;
        std::vector<glm::dvec3> vertices;  // 3 per triangle
    };
    std::vector<InstanceTriangles> instances_;
};

} // namespace penumbra::test
