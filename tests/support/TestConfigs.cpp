#include "TestConfigs.h"

#include <glm/glm.hpp>

namespace penumbra::test {

config::RenderConfig defaultTestConfig()
{
    config::RenderConfig c = config::loadConfig(std::filesystem::path(PENUMBRA_SOURCE_DIR) / "config/default.json");
    c.width = 320;
    c.height = 180;
    return c;
}

void scaleConfig(config::RenderConfig& c, float s)
{
    c.scene.scale *= s;
    c.camera.position *= s;
    c.camera.target *= s;
    c.camera.nearWorld *= s;
    for (config::LightConfig& l : c.lights) {
        l.light.position *= s;
        l.light.intensity *= s * s;
    }
}

void setLightType(config::LightConfig& lightConfig, scene::LightType type)
{
    scene::Light& light = lightConfig.light;
    light.type = type;
    switch (type) {
    case scene::LightType::Spot:
        break;
    case scene::LightType::Directional:
        light.direction = glm::normalize(glm::vec3(0.6f, -1.0f, -0.35f));
        light.intensity = 3.0f;
        break;
    case scene::LightType::Point:
        light.position = {-2.0f, 7.0f, 3.0f};
        light.intensity = 150.0f;
        break;
    case scene::LightType::Rect:
    case scene::LightType::Disk:
        light.position = {-3.0f, 9.0f, 4.0f};
        light.direction = {0.0f, -1.0f, 0.0f};
        light.sizeWorld = {1.0f, 0.5f};
        light.radiusWorld = 0.5f;
        light.intensity = 300.0f;
        break;
    }
}

} // namespace penumbra::test
