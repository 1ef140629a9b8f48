#include "CameraControl.h"

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>

namespace penumbra::viewer {
namespace {

glm::vec3 upAxis(const scene::Camera& camera)
{
    const float len = glm::length(camera.up);
    return len > 0.0f ? camera.up / len : glm::vec3(0, 1, 0);
}

// The view direction turned by yaw about `up` and by pitch towards it, kept 1 degree from the poles.
glm::vec3 turn(const glm::vec3& direction, const glm::vec3& up, float yawDeg, float pitchDeg)
{
    const float length = glm::length(direction);
    if (!(length > 0.0f)) return direction;
    glm::vec3 d = direction / length;
    d = glm::vec3(glm::rotate(glm::mat4(1.0f), glm::radians(yawDeg), up) * glm::vec4(d, 0.0f));
    const float elevation = std::asin(std::clamp(glm::dot(d, up), -1.0f, 1.0f));
    const float limit = glm::radians(89.0f);
    const float target = std::clamp(elevation + glm::radians(pitchDeg), -limit, limit);
    glm::vec3 horizontal = d - glm::dot(d, up) * up;
    const float h = glm::length(horizontal);
    if (!(h > 1e-6f)) return direction;  // straight along up: no horizontal heading to keep
    horizontal /= h;
    return (horizontal * std::cos(target) + up * std::sin(target)) * length;
}

} // namespace

scene::Camera orbit(const scene::Camera& camera, float yawDeg, float pitchDeg)
{
    scene::Camera c = camera;
    // The eye moves on the sphere about the target: turn the target-to-eye vector.
    c.position = camera.target + turn(camera.position - camera.target, upAxis(camera), yawDeg, pitchDeg);
    return c;
}

scene::Camera pan(const scene::Camera& camera, float right, float up)
{
    const glm::vec3 forward = camera.target - camera.position;
    const float distance = glm::length(forward);
    if (!(distance > 0.0f)) return camera;
    const glm::vec3 f = forward / distance;
    const glm::vec3 r = glm::normalize(glm::cross(f, upAxis(camera)));
    const glm::vec3 u = glm::cross(r, f);
    const glm::vec3 offset = (r * right + u * up) * distance;
    scene::Camera c = camera;
    c.position += offset;
    c.target += offset;
    return c;
}

scene::Camera dolly(const scene::Camera& camera, float factor, float sceneRadius)
{
    const glm::vec3 back = camera.position - camera.target;
    const float distance = glm::length(back);
    if (!(distance > 0.0f) || !(factor > 0.0f) || !std::isfinite(factor)) return camera;
    const float minimum = std::max(sceneRadius, 1e-30f) * 1e-4f;
    scene::Camera c = camera;
    c.position = camera.target + back / distance * std::max(distance * factor, minimum);
    return c;
}

scene::Camera fly(const scene::Camera& camera, float yawDeg, float pitchDeg, const glm::vec3& move, bool level)
{
    const glm::vec3 up = upAxis(camera);
    scene::Camera c = camera;
    const glm::vec3 view = turn(camera.target - camera.position, up, yawDeg, pitchDeg);
    const float distance = glm::length(view);
    if (!(distance > 0.0f)) return camera;
    glm::vec3 f = view / distance;
    const glm::vec3 r = glm::normalize(glm::cross(f, up));
    if (level) f = glm::normalize(glm::cross(up, r));  // the heading, without its climb
    const glm::vec3 offset = f * move.z + r * move.x + up * move.y;
    c.position = camera.position + offset;
    c.target = c.position + view;
    return c;
}

float flySpeed(float sceneRadius, float speedExponent)
{
    const float radius = std::isfinite(sceneRadius) && sceneRadius > 0.0f ? sceneRadius : 1.0f;
    return 0.1f * radius * std::exp2(std::clamp(speedExponent, -20.0f, 20.0f));
}

bool hasCameraTrack(const config::Animation& animation)
{
    return std::any_of(animation.tracks.begin(), animation.tracks.end(),
                       [](const config::AnimationTrack& t) { return t.target.rfind("/camera/", 0) == 0; });
}

config::RenderConfig withoutCameraTracks(config::RenderConfig config)
{
    auto& tracks = config.animation.tracks;
    tracks.erase(std::remove_if(tracks.begin(), tracks.end(),
                                [](const config::AnimationTrack& t) { return t.target.rfind("/camera/", 0) == 0; }),
                 tracks.end());
    return config;
}

} // namespace penumbra::viewer
