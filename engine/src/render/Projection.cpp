#include "penumbra/render/Projection.h"

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

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

namespace {

// Near plane for a light at `position`: half the distance to the scene box, never less
// than 1e-5 of the scene radius (reversed-Z keeps precision at any near distance, but
// casters nearer than the near plane would be clipped).
float lightNear(const glm::vec3& position, const scene::Aabb& bounds)
{
    if (bounds.empty()) return 1.0f;
    const glm::vec3 outside = glm::max(glm::max(bounds.min - position, position - bounds.max), glm::vec3(0));
    return std::max(0.5f * glm::length(outside), 1e-5f * std::max(bounds.radius(), 1e-30f));
}

LightFrustum perspectiveFrustum(const glm::vec3& position, const glm::vec3& dir, const glm::vec3& up, float fovRadians,
                                const scene::Aabb& bounds)
{
    LightFrustum f{};
    f.view = glm::lookAt(position, position + dir, up);
    f.nearWorld = lightNear(position, bounds);
    f.proj = perspectiveReversedZ(fovRadians, 1.0f, f.nearWorld);
    f.viewProj = f.proj * f.view;
    return f;
}

// Directional light: an orthographic box around the whole scene, seen along the light's
// direction. Reversed-Z like every depth buffer here: depth 1 nearest the light, 0 at
// the far side. The box is padded by 1% of the scene radius so that no caster touches
// the clip planes.
LightFrustum directionalFrustum(const scene::Light& light, const scene::Aabb& bounds, const scene::Aabb* focus)
{
    LightFrustum f{};
    const glm::vec3 dir = glm::normalize(light.direction);
    const glm::vec3 centre = bounds.empty() ? glm::vec3(0.0f) : bounds.center();
    const float radius = bounds.empty() ? 1.0f : std::max(bounds.radius(), 1e-30f);
    f.view = glm::lookAt(centre - dir * radius, centre, stableUp(dir, glm::vec3(0, 1, 0)));
    scene::Aabb box = bounds.empty() ? scene::Aabb{glm::vec3(-1.0f), glm::vec3(1.0f)} : bounds.transformed(f.view);
    if (focus && !focus->empty() && !bounds.empty()) {
        // Focused (Mattausch et al. 2011, §1.4): across the light, only the receivers'
        // box; along it, from the scene's side nearest the light (every caster in front
        // of a receiver stays in the map) to the receivers' far side.
        const scene::Aabb r = focus->transformed(f.view);
        const glm::vec3 lo = glm::max(box.min, r.min), hi = glm::min(box.max, r.max);
        if (lo.x <= hi.x && lo.y <= hi.y && lo.z <= hi.z) {
            box.min = glm::vec3(lo.x, lo.y, lo.z);
            box.max = glm::vec3(hi.x, hi.y, box.max.z);
        }
    }
    const float pad = 0.01f * radius;
    box.min -= pad;
    box.max += pad;
    // View space looks down -z: distance along the light d = -z, from -box.max.z to -box.min.z.
    const float dNear = -box.max.z, dFar = -box.min.z;
    glm::mat4 m(1.0f);
    m[0][0] = 2.0f / (box.max.x - box.min.x);
    m[3][0] = -(box.max.x + box.min.x) / (box.max.x - box.min.x);
    m[1][1] = -2.0f / (box.max.y - box.min.y);  // Vulkan clip space: y down
    m[3][1] = (box.max.y + box.min.y) / (box.max.y - box.min.y);
    // depth = (dFar - d) / (dFar - dNear) with d = -z: 1 at dNear, 0 at dFar.
    m[2][2] = 1.0f / (dFar - dNear);
    m[3][2] = dFar / (dFar - dNear);
    f.proj = m;
    f.viewProj = f.proj * f.view;
    f.nearWorld = dNear;
    return f;
}

// Focused spot light (Mattausch et al. 2011, §1.4): the cone narrowed about its own axis
// to the box of what the camera sees, plus 1 % for rounding. Every point the camera sees
// stays in it, and so does every caster between such a point and the light, since the
// cone is convex from its apex. Returns +inf (keep the cone) when a corner of the box
// lies at or behind the near plane: the box then reaches around the light. The narrowest
// cone is 1e-4 of a radian wide, so that the matrix stays well conditioned.
float focusedTanHalfAngle(const LightFrustum& f, const scene::Aabb& focus)
{
    float tanHalf = 0.0f;
    for (int c = 0; c < 8; ++c) {
        const glm::vec4 v = f.view * glm::vec4(focus.corner(c), 1.0f);
        const float distance = -v.z;  // along the light's axis
        if (!(distance > f.nearWorld)) return std::numeric_limits<float>::infinity();
        tanHalf = std::max(tanHalf, std::max(std::abs(v.x), std::abs(v.y)) / distance);
    }
    return std::max(1.01f * tanHalf, 5e-5f);
}

} // namespace

std::vector<LightFrustum> shadowFrusta(const scene::Light& light, const scene::Aabb& bounds, const scene::Aabb* focus,
                                       float cubeHalfTan)
{
    switch (light.type) {
    case scene::LightType::Directional:
        return {directionalFrustum(light, bounds, focus)};
    case scene::LightType::Spot: {
        // The frustum covers the cone: its half-angle is the outer cone's (below 90° by
        // config validation).
        const glm::vec3 dir = glm::normalize(light.direction);
        const glm::vec3 up = stableUp(dir, glm::vec3(0, 1, 0));
        const float fov = 2.0f * glm::radians(light.outerConeDeg);
        LightFrustum f = perspectiveFrustum(light.position, dir, up, fov, bounds);
        if (focus && !focus->empty()) {
            const float tanHalf = focusedTanHalfAngle(f, *focus);
            if (tanHalf < std::tan(0.5f * fov))
                f = perspectiveFrustum(light.position, dir, up, 2.0f * std::atan(tanHalf), bounds);
        }
        return {f};
    }
    case scene::LightType::Point:
    case scene::LightType::Rect:
    case scene::LightType::Disk: {
        // Six faces around the centre, in the order +X -X +Y -Y +Z -Z that
        // shaders/common/shadow_map.glsl selects by the dominant axis: 90° each, plus the
        // guard band (a NaN or a value below 1 gives 90°; at most 16, 172°).
        static const glm::vec3 axes[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
        static const glm::vec3 ups[6] = {{0, 1, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, 1}, {0, 1, 0}, {0, 1, 0}};
        const float fov = 2.0f * std::atan(cubeHalfTan >= 1.0f ? std::min(cubeHalfTan, 16.0f) : 1.0f);
        std::vector<LightFrustum> faces;
        for (int i = 0; i < 6; ++i) faces.push_back(perspectiveFrustum(light.position, axes[i], ups[i], fov, bounds));
        return faces;
    }
    }
    return {};
}

} // namespace penumbra::render
