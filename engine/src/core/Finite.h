#pragma once
// Finite-value checks shared by the modules that take geometry from files (the BVH, mesh
// repair): a NaN or an infinity in one coordinate makes the whole point unusable.
#include <glm/vec3.hpp>

#include <cmath>

namespace penumbra::core {

inline bool isFinite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

} // namespace penumbra::core
