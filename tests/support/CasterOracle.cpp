#include "CasterOracle.h"

#include "penumbra/scene/Bvh.h"

#include <cmath>

namespace penumbra::test {
namespace {

// Möller-Trumbore, double precision; hits with t > 0.
bool hitsTriangle(const glm::dvec3& o, const glm::dvec3& d, const glm::dvec3& a, const glm::dvec3& b,
                  const glm::dvec3& c)
{
    const glm::dvec3 e1 = b - a, e2 = c - a, p = glm::cross(d, e2);
    const double det = glm::dot(e1, p);
    if (std::abs(det) < 1e-300) return false;
    const double inv = 1.0 / det;
    const glm::dvec3 s = o - a;
    const double u = glm::dot(s, p) * inv;
    if (u < 0.0 || u > 1.0) return false;
    const glm::dvec3 q = glm::cross(s, e1);
    const double v = glm::dot(d, q) * inv;
    if (v < 0.0 || u + v > 1.0) return false;
    return glm::dot(e2, q) * inv > 0.0;
}

} // namespace

CasterOracle casterOracle(const scene::Scene& scene, const std::vector<float>& positions,
                          const std::vector<float>& normals, const glm::dvec3& towardsLight)
{
    CasterOracle oracle;
    oracle.shadows.assign(scene.instances.size(), 0);
    const scene::InstanceBvh bvh(scene::instanceWorldBounds(scene.instances));
    // Off the surface along its normal, by a part of the scene's size that fp32 positions
    // resolve, so that a pixel's own triangle does not count.
    const double offset = 1e-4 * scene.bounds().radius();
    std::vector<scene::RayHit> hits;
    for (size_t px = 0; 4 * px + 3 < positions.size() && 4 * px + 2 < normals.size(); ++px) {
        if (positions[4 * px + 3] == 0.0f) continue;
        const glm::dvec3 n(normals[4 * px], normals[4 * px + 1], normals[4 * px + 2]);
        if (glm::dot(n, towardsLight) <= 0.0) continue;
        const glm::dvec3 o = glm::dvec3(positions[4 * px], positions[4 * px + 1], positions[4 * px + 2]) + offset * n;
        bvh.findAllHits({glm::vec3(o), glm::vec3(towardsLight)}, hits);
        for (const scene::RayHit& h : hits) {
            if (oracle.shadows[h.instance]) continue;
            const scene::Instance& inst = scene.instances[h.instance];
            const scene::Mesh& mesh = scene.meshes[inst.mesh];
            const glm::dmat4 m(scene.instanceTransform(inst));
            for (size_t t = 0; t + 2 < mesh.indices.size() && !oracle.shadows[h.instance]; t += 3) {
                glm::dvec3 v[3];
                for (int k = 0; k < 3; ++k)
                    v[k] = glm::dvec3(m * glm::dvec4(glm::dvec3(mesh.vertices[mesh.indices[t + k]].position), 1.0));
                if (hitsTriangle(o, towardsLight, v[0], v[1], v[2])) oracle.shadows[h.instance] = 1;
            }
        }
    }
    for (size_t i = 0; i < oracle.shadows.size(); ++i)
        if (oracle.shadows[i]) oracle.triangles += scene.meshes[scene.instances[i].mesh].indices.size() / 3;
    return oracle;
}

} // namespace penumbra::test
