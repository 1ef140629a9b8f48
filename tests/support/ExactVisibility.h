#pragma once
// Closed forms of exact visibility that several technique tests compare with.
#include <glm/glm.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

namespace penumbra::test {

// The area fraction of a unit disk beyond a chord at signed distance h from its centre
// (h = 1: the whole disk, 0: half, -1: none): what a disk light of radius r holds beyond
// a plane that its centre lies h r before.
inline double diskBeyondChord(double h)
{
    h = std::clamp(h, -1.0, 1.0);
    return (std::acos(-h) + h * std::sqrt(1.0 - h * h)) / std::numbers::pi;
}

// Exact visibility of a planar convex area light past one planar convex occluder: the
// light polygon clipped by the planes through the receiver and each occluder edge, and
// by the occluder's own plane.
using Polygon = std::vector<glm::dvec3>;

// The part of `polygon` (planar, convex) where dot(n, x - p) >= 0.
inline Polygon clipPolygon(const Polygon& polygon, const glm::dvec3& n, const glm::dvec3& p)
{
    Polygon out;
    for (size_t i = 0; i < polygon.size(); ++i) {
        const glm::dvec3 &a = polygon[i], &b = polygon[(i + 1) % polygon.size()];
        const double da = glm::dot(n, a - p), db = glm::dot(n, b - p);
        if (da >= 0.0) out.push_back(a);
        if ((da >= 0.0) != (db >= 0.0)) out.push_back(a + (b - a) * (da / (da - db)));
    }
    return out;
}

inline double polygonArea(const Polygon& polygon)
{
    if (polygon.size() < 3) return 0.0;
    glm::dvec3 sum(0.0);
    for (size_t i = 1; i + 1 < polygon.size(); ++i)
        sum += glm::cross(polygon[i] - polygon[0], polygon[i + 1] - polygon[0]);
    return 0.5 * glm::length(sum);
}

// The share of `light` that the convex occluder `occluder` (its corners in order, in
// one plane) hides from the receiver point p, which lies on the other side of the
// occluder's plane from the part of the light counted: the light inside the pyramid
// from p through the occluder's edges, beyond the occluder's plane.
inline double hiddenShare(const Polygon& light, const Polygon& occluder, const glm::dvec3& p)
{
    glm::dvec3 centre(0.0);
    for (const glm::dvec3& c : occluder) centre += c / double(occluder.size());
    glm::dvec3 normal = glm::cross(occluder[1] - occluder[0], occluder[2] - occluder[0]);
    if (glm::dot(normal, p - centre) > 0.0) normal = -normal;  // away from the receiver
    Polygon hidden = clipPolygon(light, normal, centre);
    for (size_t i = 0; i < occluder.size() && hidden.size() >= 3; ++i) {
        glm::dvec3 n = glm::cross(occluder[i] - p, occluder[(i + 1) % occluder.size()] - p);
        if (glm::dot(n, centre - p) < 0.0) n = -n;  // the side the occluder's centre is on
        hidden = clipPolygon(hidden, n, p);
    }
    const double whole = polygonArea(light);
    return hidden.size() >= 3 && whole > 0.0 ? polygonArea(hidden) / whole : 0.0;
}

} // namespace penumbra::test
