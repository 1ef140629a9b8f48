#include "penumbra/render/Projection.h"

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>

namespace penumbra::render {

glm::mat4 perspectiveReversedZ(float fovYRadians, float aspect, float nearWorld)
{
    const float f = 1.0f / std::tan(0.5f * fovYRadians);
    glm::mat4 m(0.0f);
    m[0][0] = f / aspect;
    m[1][1] = -f;  // Vulkan clip space: y down
    m[2][3] = -1.0f;  // w = -z_view (right-handed view looking down -z)
    m[3][2] = nearWorld;  // z = near, so depth = near / -z_view
    return m;
}

namespace {

// An up vector that is not parallel to `forward`.
glm::vec3 stableUp(const glm::vec3& forward, const glm::vec3& preferred)
{
    if (glm::length(glm::cross(forward, preferred)) > 1e-3f * glm::length(preferred)) return preferred;
    return std::abs(forward.y) < 0.9f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0);
}

} // namespace

glm::mat4 cameraView(const scene::Camera& camera)
{
    const glm::vec3 forward = glm::normalize(camera.target - camera.position);
    return glm::lookAt(camera.position, camera.target, stableUp(forward, camera.up));
}

glm::mat4 cameraViewProj(const scene::Camera& camera, float aspect)
{
    return perspectiveReversedZ(glm::radians(camera.fovYDeg), aspect, camera.nearWorld) * cameraView(camera);
}

LightFrustum spotLightFrustum(const scene::Light& light, const scene::Aabb& bounds)
{
    LightFrustum f{};
    const glm::vec3 dir = glm::normalize(light.direction);
    f.view = glm::lookAt(light.position, light.position + dir, stableUp(dir, glm::vec3(0, 1, 0)));
    // Distance from the light to the scene box (0 when the light is inside it).
    const glm::vec3 outside = glm::max(glm::max(bounds.min - light.position, light.position - bounds.max), glm::vec3(0));
    const float distance = bounds.empty() ? 1.0f : glm::length(outside);
    const float radius = bounds.empty() ? 1.0f : std::max(bounds.radius(), 1e-30f);
    f.nearWorld = std::max(0.5f * distance, 1e-5f * radius);
    // The frustum covers the cone: its half-angle is the outer cone's (clamped below 90°
    // by config validation).
    f.proj = perspectiveReversedZ(2.0f * glm::radians(light.outerConeDeg), 1.0f, f.nearWorld);
    f.viewProj = f.proj * f.view;
    return f;
}

} // namespace penumbra::render
