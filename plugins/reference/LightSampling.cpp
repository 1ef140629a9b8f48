#include "LightSampling.h"

#include <cmath>
#include <limits>
#include <numbers>

namespace penumbra::reference {
namespace {

// A permutation of [0, length) chosen by `p` (Kensler 2013, listing 3). Every step is a
// bijection on the low bits that `mask` keeps, so cycle-walking (repeating while the
// result is out of range) visits each index once.
uint32_t permute(uint32_t i, uint32_t length, uint32_t p)
{
    uint32_t mask = length - 1;
    mask |= mask >> 1;
    mask |= mask >> 2;
    mask |= mask >> 4;
    mask |= mask >> 8;
    mask |= mask >> 16;
    do {
        i ^= p;
        i *= 0xe170893d;
        i ^= p >> 16;
        i ^= (i & mask) >> 4;
        i ^= p >> 8;
        i *= 0x0929eb3f;
        i ^= p >> 23;
        i ^= (i & mask) >> 1;
        i *= 1 | p >> 27;
        i *= 0x6935fa69;
        i ^= (i & mask) >> 11;
        i *= 0x74dcb303;
        i ^= (i & mask) >> 2;
        i *= 0x9e501cc3;
        i ^= (i & mask) >> 2;
        i *= 0xc860a3df;
        i &= mask;
        i ^= i >> 5;
    } while (i >= length);
    return (i + p) % length;
}

// A float in [0, 1) from (i, p) (Kensler 2013, listing 4).
float randomFloat(uint32_t i, uint32_t p)
{
    i ^= p;
    i ^= i >> 17;
    i ^= i >> 10;
    i *= 0xb36534e5;
    i ^= i >> 12;
    i ^= i >> 21;
    i *= 0x93fc4795;
    i ^= 0xdf6e307f;
    i ^= i >> 17;
    i *= 1 | p >> 18;
    return float(i) * (1.0f / 4294967808.0f);
}

// An orthonormal basis around unit `n` without a branch on a near-parallel axis (Duff
// et al. 2017, "Building an Orthonormal Basis, Revisited").
void basisAround(const glm::dvec3& n, glm::dvec3& t, glm::dvec3& b)
{
    const double sign = std::copysign(1.0, n.z);
    const double a = -1.0 / (sign + n.z);
    const double c = n.x * n.y * a;
    t = {1.0 + sign * n.x * n.x * a, sign * c, -sign * n.x};
    b = {c, sign + n.y * n.y * a, -n.y};
}

// Uniform over the cone of directions within the angle whose 1 - cos is `oneMinusCos`
// around `axis`: cos(theta) uniform in [cos(max), 1], an equal-area map of the square.
glm::dvec3 sampleCone(const glm::dvec3& axis, const glm::dvec3& t, const glm::dvec3& b, double oneMinusCos,
                      glm::vec2 u)
{
    const double oneMinusCosTheta = double(u.x) * oneMinusCos;
    const double cosTheta = 1.0 - oneMinusCosTheta;
    const double sinTheta = std::sqrt(std::max(0.0, oneMinusCosTheta * (2.0 - oneMinusCosTheta)));
    const double phi = 2.0 * std::numbers::pi * double(u.y);
    return glm::normalize(cosTheta * axis + sinTheta * (std::cos(phi) * t + std::sin(phi) * b));
}

// Shirley and Chiu's concentric map of the square onto the unit disk: equal-area and
// low-distortion, so the square's strata stay compact on the disk.
glm::dvec2 concentricDisk(glm::vec2 u)
{
    const double a = 2.0 * u.x - 1.0, b = 2.0 * u.y - 1.0;
    if (a == 0.0 && b == 0.0) return {0.0, 0.0};
    const double quarter = std::numbers::pi / 4.0;
    if (std::abs(a) > std::abs(b)) return a * glm::dvec2(std::cos(quarter * b / a), std::sin(quarter * b / a));
    const double phi = 2.0 * quarter - quarter * a / b;
    return b * glm::dvec2(std::cos(phi), std::sin(phi));
}

// 1 - sqrt(1 - s²) without cancellation for small s.
double oneMinusCosFromSin(double s) { return s * s / (1.0 + std::sqrt(std::max(0.0, 1.0 - s * s))); }

ShadowRay towards(const glm::dvec3& origin, const glm::dvec3& target)
{
    const glm::dvec3 d = target - origin;
    const double length = glm::length(d);
    if (!(length > 0.0)) return {};
    return {d / length, length};
}

} // namespace

uint32_t mixBits(uint32_t x)
{
    x ^= x >> 16;
    x *= 0x7feb352d;
    x ^= x >> 15;
    x *= 0x846ca68b;
    x ^= x >> 16;
    return x;
}

glm::vec2 stratifiedSample(uint32_t index, uint32_t count, uint32_t pattern)
{
    const auto m = uint32_t(std::sqrt(double(count)));
    const uint32_t n = (count + m - 1) / m;
    const uint32_t s = permute(index, count, pattern * 0x51633e2d);
    const uint32_t sx = permute(s % m, m, pattern * 0xa511e9b3);
    const uint32_t sy = permute(s / m, n, pattern * 0x63d83595);
    const float jx = randomFloat(s, pattern * 0xa399d265);
    const float jy = randomFloat(s, pattern * 0x711ad6a5);
    const glm::vec2 u{(float(s % m) + (float(sy) + jx) / float(n)) / float(m),
                      (float(s / m) + (float(sx) + jy) / float(m)) / float(n)};
    // Float rounding may reach 1 exactly; the square is half-open.
    return glm::min(u, glm::vec2(std::nextafter(1.0f, 0.0f)));
}

LightSampler::LightSampler(const scene::Light& light) : light_(light)
{
    const double length = glm::length(glm::dvec3(light.direction));
    axis_ = length > 0.0 ? glm::dvec3(light.direction) / length : glm::dvec3(0.0, -1.0, 0.0);
    switch (light.type) {
    case scene::LightType::Spot: break;
    case scene::LightType::Point: extended_ = light.radiusWorld > 0.0f; break;
    case scene::LightType::Directional: {
        axis_ = -axis_;
        const double halfAngle = 0.5 * double(light.angularDiameterDeg) * std::numbers::pi / 180.0;
        const double s = std::sin(0.5 * halfAngle);
        oneMinusCosSun_ = 2.0 * s * s;  // 1 - cos(x) = 2 sin²(x / 2), exact for tiny suns
        extended_ = oneMinusCosSun_ > 0.0;
        basisAround(axis_, tangent_, bitangent_);
        break;
    }
    case scene::LightType::Rect: {
        extended_ = light.sizeWorld.x > 0.0f || light.sizeWorld.y > 0.0f;
        // The config makes the tangent unit and normal to the direction; make sure.
        glm::dvec3 t = glm::dvec3(light.tangent) - glm::dot(glm::dvec3(light.tangent), axis_) * axis_;
        if (!(glm::length(t) > 1e-6)) basisAround(axis_, t, bitangent_);
        tangent_ = glm::normalize(t);
        bitangent_ = glm::cross(axis_, tangent_);
        break;
    }
    case scene::LightType::Disk:
        extended_ = light.radiusWorld > 0.0f;
        basisAround(axis_, tangent_, bitangent_);
        break;
    }
}

ShadowRay LightSampler::sample(const glm::dvec3& origin, glm::vec2 u) const
{
    const glm::dvec3 centre(light_.position);
    switch (light_.type) {
    case scene::LightType::Spot: return towards(origin, centre);
    case scene::LightType::Directional: {
        if (!extended_) return {axis_, std::numeric_limits<double>::infinity()};
        return {sampleCone(axis_, tangent_, bitangent_, oneMinusCosSun_, u), std::numeric_limits<double>::infinity()};
    }
    case scene::LightType::Point: {
        const double radius = light_.radiusWorld;
        if (!extended_) return towards(origin, centre);
        const ShadowRay toCentre = towards(origin, centre);
        const double d = toCentre.length;
        if (d <= radius) return {};  // inside the sphere: nothing lies between
        // The cone the sphere subtends; each direction ends where it meets the sphere.
        glm::dvec3 t, b;
        basisAround(toCentre.direction, t, b);
        const glm::dvec3 dir = sampleCone(toCentre.direction, t, b, oneMinusCosFromSin(radius / d), u);
        const double cosTheta = glm::dot(dir, toCentre.direction);
        const double along = d * cosTheta;
        const double across2 = std::max(0.0, radius * radius - (d * d - along * along));
        return {dir, std::max(0.0, along - std::sqrt(across2))};
    }
    case scene::LightType::Rect:
    case scene::LightType::Disk: return towards(origin, areaPoint(u));
    }
    return towards(origin, centre);
}

glm::dvec3 LightSampler::areaPoint(glm::vec2 u) const
{
    const glm::dvec2 offset = light_.type == scene::LightType::Rect
                                  ? (glm::dvec2(u) - 0.5) * glm::dvec2(light_.sizeWorld)
                                  : concentricDisk(u) * double(light_.radiusWorld);
    return glm::dvec3(light_.position) + offset.x * tangent_ + offset.y * bitangent_;
}

LightPoint LightSampler::fixedSample(glm::vec2 u) const
{
    const glm::dvec3 centre(light_.position);
    switch (light_.type) {
    case scene::LightType::Spot: return {centre, false};
    case scene::LightType::Directional:
        if (!extended_) return {axis_, true};
        return {sampleCone(axis_, tangent_, bitangent_, oneMinusCosSun_, u), true};
    case scene::LightType::Point: {
        if (!extended_) return {centre, false};
        // Uniform on the sphere by area: z uniform in [-1, 1] (Archimedes' hat-box).
        const double z = 1.0 - 2.0 * double(u.x);
        const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
        const double phi = 2.0 * std::numbers::pi * double(u.y);
        return {centre + double(light_.radiusWorld) * glm::dvec3(r * std::cos(phi), r * std::sin(phi), z), false};
    }
    case scene::LightType::Rect:
    case scene::LightType::Disk: return {areaPoint(u), false};
    }
    return {centre, false};
}

} // namespace penumbra::reference
