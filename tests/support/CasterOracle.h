#pragma once
// The caster oracle of the visibility service's figures (docs/culling.md): the instances
// that really shadow a visible pixel under a directional light, found by casting each
// lit-facing G-buffer pixel's shadow ray over the instances' triangles (CPU, double
// precision). Shared by the culling tests and bench_culling.cpp.
#include "penumbra/scene/Scene.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <vector>

namespace penumbra::test {

struct CasterOracle {
    std::vector<uint8_t> shadows;  // per instance: 1 when it blocks some pixel's shadow ray
    uint64_t triangles = 0;        // the triangles of those instances
};

// `positions` and `normals` are the G-buffer's (readPositions / readNormals: RGBA per
// pixel, position w = 0 where nothing was drawn); `towardsLight` is the unit direction
// to the light. Pixels whose normal faces away from the light are skipped: the horizon
// shadows them, not a caster.
CasterOracle casterOracle(const scene::Scene& scene, const std::vector<float>& positions,
                          const std::vector<float>& normals, const glm::dvec3& towardsLight);

} // namespace penumbra::test
