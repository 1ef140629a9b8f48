#pragma once
// Where the shadow rays of one receiver point go: stratified samples over the light's
// extent (README.md, "Method"). Each light is a set of points or directions with a
// uniform measure: a rectangle or disk by area, a sphere by the solid angle it subtends
// from the receiver, the sun by the cone of directions of its angular diameter. V is
// the fraction of that measure the receiver sees unoccluded; a light without extent is
// one sample.
#include "penumbra/scene/Scene.h"

#include <glm/glm.hpp>

#include <cstdint>

namespace penumbra::reference {

// A point of the unit square, sample `index` of `count` in a correlated multi-jittered
// pattern (Kensler 2013, "Correlated Multi-Jittered Sampling", Pixar technical memo
// 13-01): jittered in an m x n grid of cells (m = floor(sqrt(count))) and stratified in
// each axis alone, for any count. `pattern` decorrelates the patterns of neighbouring
// pixels; the same (index, count, pattern) always gives the same point.
glm::vec2 stratifiedSample(uint32_t index, uint32_t count, uint32_t pattern);

// A well-mixed 32-bit hash (integer finaliser), for per-pixel pattern seeds.
uint32_t mixBits(uint32_t x);

struct ShadowRay {
    glm::dvec3 direction{0.0};  // unit, from the receiver towards the light sample
    double length = 0.0;        // to the sample; +inf for a directional light; 0: no ray (the sample is not
                                // separated from the receiver, counted as unoccluded)
};

// A light sample shared by every receiver (the rasterised reference renders one shadow
// map from each): a point of the light, or for a directional light a unit direction
// towards it.
struct LightPoint {
    glm::dvec3 value{0.0};
    bool isDirection = false;
};

class LightSampler {
public:
    explicit LightSampler(const scene::Light& light);

    // Samples per pixel for a requested count: 1 when the light has no extent (spot,
    // point without radius, directional with angular diameter 0, rect 0 x 0, disk of
    // radius 0), where every sample would be the same ray.
    uint32_t sampleCount(uint32_t requested) const { return extended_ ? requested : 1u; }

    // The ray from `origin` to the light point (or direction) that `u` (in the unit
    // square) maps to. Uniform `u` gives the uniform measure described above.
    ShadowRay sample(const glm::dvec3& origin, glm::vec2 u) const;

    // The light sample that `u` maps to, the same for every receiver: rect and disk the
    // point sample() aims at (uniform by area); directional the direction of the cone
    // (uniform by solid angle); a sphere (point with radius) a point of its surface,
    // uniform by area, which a receiver weights by the solid angle that piece of the
    // surface subtends (the rasterised reference does); lights without extent their
    // centre (or direction).
    LightPoint fixedSample(glm::vec2 u) const;

private:
    // Rect and disk: the point of the light that `u` maps to.
    glm::dvec3 areaPoint(glm::vec2 u) const;

    scene::Light light_;
    bool extended_ = false;
    glm::dvec3 axis_{0.0};  // rect, disk: emitting normal; directional: towards the light
    glm::dvec3 tangent_{0.0}, bitangent_{0.0};
    double oneMinusCosSun_ = 0.0;  // directional: 1 - cos(angular radius)
};

} // namespace penumbra::reference
