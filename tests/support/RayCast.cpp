#include "RayCast.h"

#include <algorithm>
#include <cmath>

namespace penumbra::test {

RayCaster::RayCaster(const scene::Scene& scene)
{
    for (const scene::Instance& inst : scene.instances) {
        InstanceTriangles t;
        const scene::Mesh& mesh = scene.meshes.at(inst.mesh);
        const glm::dmat4 m(scene.instanceTransform(inst));
        t.boxMin = glm::dvec3(std::numeric_limits<double>::max());
        t.boxMax = -t.boxMin;
        for (uint32_t index : mesh.indices) {
            const glm::dvec3 p = glm::dvec3(m * glm::dvec4(glm::dvec3(mesh.vertices[index].position), 1.0));
            t.vertices.push_back(p);
            t.boxMin = glm::min(t.boxMin, p);
            t.boxMax = glm::max(t.boxMax, p);
        }
        instances_.push_back(std::move(t));
    }
}

namespace {

// Slab test of the segment origin + t·dir, t in [0, 1], against a box.
bool segmentHitsBox(const glm::dvec3& o, const glm::dvec3& d, const glm::dvec3& lo, const glm::dvec3& hi)
{
    double t0 = 0.0, t1 = 1.0;
    for (int a = 0; a < 3; ++a) {
        if (std::abs(d[a]) < 1e-300) {
            if (o[a] < lo[a] || o[a] > hi[a]) return false;
            continue;
        }
        double ta = (lo[a] - o[a]) / d[a], tb = (hi[a] - o[a]) / d[a];
        if (ta > tb) std::swap(ta, tb);
        t0 = std::max(t0, ta);
        t1 = std::min(t1, tb);
        if (t0 > t1) return false;
    }
    return true;
}

// Möller–Trumbore: the ray parameter t of the hit (o + t·d), or -1 for a miss.
double rayTriangle(const glm::dvec3& o, const glm::dvec3& d, const glm::dvec3& a, const glm::dvec3& b,
                   const glm::dvec3& c)
{
    const glm::dvec3 e1 = b - a, e2 = c - a;
    const glm::dvec3 p = glm::cross(d, e2);
    const double det = glm::dot(e1, p);
    if (det == 0.0) return -1.0;
    const double inv = 1.0 / det;
    const glm::dvec3 s = o - a;
    const double u = glm::dot(s, p) * inv;
    if (u < 0.0 || u > 1.0) return -1.0;
    const glm::dvec3 q = glm::cross(s, e1);
    const double v = glm::dot(d, q) * inv;
    if (v < 0.0 || u + v > 1.0) return -1.0;
    return glm::dot(e2, q) * inv;
}

} // namespace

bool RayCaster::segmentBlocked(const glm::dvec3& from, const glm::dvec3& to) const
{
    const glm::dvec3 d = to - from;
    for (const InstanceTriangles& inst : instances_) {
        if (!segmentHitsBox(from, d, inst.boxMin, inst.boxMax)) continue;
        for (size_t i = 0; i + 2 < inst.vertices.size(); i += 3) {
            const double t = rayTriangle(from, d, inst.vertices[i], inst.vertices[i + 1], inst.vertices[i + 2]);
            if (t > 0.0 && t < 1.0) return true;
        }
    }
    return false;
}

double RayCaster::closestHit(const glm::dvec3& origin, const glm::dvec3& dir) const
{
    double best = std::numeric_limits<double>::infinity();
    // A segment long enough to leave every box: from the origin past the farthest corner.
    for (const InstanceTriangles& inst : instances_) {
        const double reach = glm::length(glm::max(glm::abs(inst.boxMin - origin), glm::abs(inst.boxMax - origin))) * 2.0;
        if (!segmentHitsBox(origin, dir * reach, inst.boxMin, inst.boxMax)) continue;
        for (size_t i = 0; i + 2 < inst.vertices.size(); i += 3) {
            const double t = rayTriangle(origin, dir, inst.vertices[i], inst.vertices[i + 1], inst.vertices[i + 2]);
            if (t > 0.0 && t < best) best = t;
        }
    }
    return best;
}

} // namespace penumbra::test
