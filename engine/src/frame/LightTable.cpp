#include "frame/LightTable.h"

#include <cmath>

namespace penumbra::frame {

void writeLightTable(std::span<const scene::Light> lights, LightData* rows)
{
    static_assert(int(scene::LightType::Directional) == 0 && int(scene::LightType::Spot) == 1 &&
                      int(scene::LightType::Point) == 2 && int(scene::LightType::Rect) == 3 &&
                      int(scene::LightType::Disk) == 4,
                  "type codes in shaders/common/light.glsl");
    for (size_t i = 0; i < lights.size(); ++i) {
        const scene::Light& l = lights[i];
        rows[i].positionWorld = glm::vec4(l.position, float(int(l.type)));
        rows[i].direction = glm::vec4(glm::normalize(l.direction), std::cos(glm::radians(l.outerConeDeg)));
        rows[i].radiance = glm::vec4(l.color * l.intensity, std::cos(glm::radians(l.innerConeDeg)));
    }
}

} // namespace penumbra::frame
