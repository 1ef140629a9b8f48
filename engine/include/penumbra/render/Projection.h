#pragma once
// View and projection matrices. Every depth buffer in the engine is reversed-Z with an
// infinite far plane: NDC depth = near / viewDepth, 1 at the near plane, 0 at infinity.
// With a float depth buffer this keeps a near-constant relative precision at every
// distance, which is what tiny and huge scenes need. Clip space is Vulkan's (y down).
#include "penumbra/scene/Scene.h"

#include <glm/glm.hpp>

#include <vector>

namespace penumbra::render {

glm::mat4 perspectiveReversedZ(float fovYRadians, float aspect, float nearWorld);

glm::mat4 cameraView(const scene::Camera& camera);
glm::mat4 cameraViewProj(const scene::Camera& camera, float aspect);

// A light's shadow frusta: one for spot lights (covering the outer cone) and directional
// lights (an orthographic box around the scene), six 90° cube faces (+X -X +Y -Y +Z -Z)
// for point, rect and disk lights (hard shadows treat those as their centre point).
// Near planes are fitted to the scene bounds.
struct LightFrustum {
    glm::mat4 view;
    glm::mat4 proj;
    glm::mat4 viewProj;
    float nearWorld;
};
// `focus`, when given and not empty: the box of what the camera sees (shadow-map
// focusing). A directional light's box is then fitted to it across the light and on its
// far side, and keeps the scene's side nearest the light; a spot light's cone is
// narrowed about its axis to it. Cube maps (point, rect, disk lights) ignore it: their
// six faces already cover every direction.
//
// `cubeHalfTan` (>= 1): a cube face spans ±cubeHalfTan in tan about its axis, 1 for
// exactly 90°; more gives each face a guard band beyond its 90° that overlaps its
// neighbours (ShadowMap's guard texels: filter taps near a cube edge read the texels
// beyond it in the receiver's own face). Face i's axis and up are as for 90°.
std::vector<LightFrustum> shadowFrusta(const scene::Light& light, const scene::Aabb& sceneBounds,
                                       const scene::Aabb* focus = nullptr, float cubeHalfTan = 1.0f);

} // namespace penumbra::render
