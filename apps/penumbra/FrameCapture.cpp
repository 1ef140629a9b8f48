#include "FrameCapture.h"

#include <glm/glm.hpp>

#include <cmath>

namespace penumbra::app {

FrameImages captureFrame(const frame::FrameRenderer& renderer)
{
    FrameImages images;
    images.width = renderer.width();
    images.height = renderer.height();
    images.color = renderer.readColor();
    images.positions = renderer.readPositions();
    for (size_t i = 0; i < renderer.lightCount(); ++i) {
        images.visibility.push_back(renderer.readVisibility(i));
        images.techniques.push_back(renderer.techniqueName(i));
    }
    return images;
}

metrics::PixelMask reachMask(const scene::Light& light, uint32_t width, uint32_t height, std::span<const float> positions)
{
    metrics::PixelMask mask = metrics::geometryMask(width, height, positions);
    if (light.type != scene::LightType::Spot) return mask;
    // shaders/common/light.glsl spotFactor: smoothstep(cos outer, cos inner, cos angle) is
    // 0 wherever the angle from the axis is at least the outer half-angle.
    const glm::dvec3 axis = glm::normalize(glm::dvec3(light.direction));
    const double cosOuter = std::cos(glm::radians(double(light.outerConeDeg)));
    for (size_t i = 0; i < mask.covered.size(); ++i) {
        if (!mask.covered[i]) continue;
        const glm::dvec3 p(positions[4 * i], positions[4 * i + 1], positions[4 * i + 2]);
        const glm::dvec3 d = p - glm::dvec3(light.position);
        const double length = glm::length(d);
        // A point at the light itself is lit (shading's own guard keeps it finite).
        const bool inCone = !(length > 0.0) || glm::dot(d, axis) > cosOuter * length;
        mask.covered[i] = inCone ? 1 : 0;
    }
    return mask;
}

} // namespace penumbra::app
