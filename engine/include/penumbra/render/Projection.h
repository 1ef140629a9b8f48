#pragma once
// View and projection matrices. Every depth buffer in the engine is reversed-Z with an
// infinite far plane: NDC depth = near / viewDepth, 1 at the near plane, 0 at infinity.
// With a float depth buffer this keeps a near-constant relative precision at every
// distance, which is what tiny and huge scenes need. Clip space is Vulkan's (y down).
#include "penumbra/scene/Scene.h"

#include <glm/glm.hpp>

namespace penumbra::render {

glm::mat4 perspectiveReversedZ(float fovYRadians, float aspect, float nearWorld);

glm::mat4 cameraView(const scene::Camera& camera);
glm::mat4 cameraViewProj(const scene::Camera& camera, float aspect);

// The spot light's shadow frustum: square, covering the outer cone, with a near plane
// fitted to the scene bounds (the closest the scene comes to the light, never less than
// 1e-5 of the scene radius).
struct LightFrustum {
    glm::mat4 view;
    glm::mat4 proj;
    glm::mat4 viewProj;
    float nearWorld;
};
LightFrustum spotLightFrustum(const scene::Light& light, const scene::Aabb& sceneBounds);

} // namespace penumbra::render
