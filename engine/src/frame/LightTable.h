#pragma once
// The lights as shaders read them (shaders/common/light.glsl LightData): one std430 row
// per light, written into a host-visible buffer by every pass that lights the scene (the
// frame's shading, the floor's forward draw), so that both light the same way.
#include "penumbra/scene/Scene.h"

#include <glm/glm.hpp>

#include <span>

namespace penumbra::frame {

struct LightData {  // matches shaders/common/light.glsl
    glm::vec4 positionWorld;
    glm::vec4 direction;
    glm::vec4 radiance;
};

// The sky: rgb irradiance / pi of the hemispherical ambient, w = exposure; and the linear
// colour where no geometry is seen.
inline const glm::vec4 kSkyAmbient{0.035f, 0.04f, 0.05f, 1.0f};
inline const glm::vec4 kBackground{0.55f, 0.65f, 0.8f, 1.0f};

// Writes one row per light into `rows` (which holds at least lights.size()).
void writeLightTable(std::span<const scene::Light> lights, LightData* rows);

} // namespace penumbra::frame
