#include "BenchContext.h"

namespace penumbra::bench {

gpu::Context& context()
{
    static gpu::Context instance(gpu::ContextOptions{{}, false});
    return instance;
}

plugin::PluginRegistry& registry()
{
    static plugin::PluginRegistry instance;
    return instance;
}

config::LightConfig hardSun(glm::vec3 direction)
{
    config::LightConfig light;
    light.name = "sun";
    light.light.type = scene::LightType::Directional;
    light.light.direction = glm::normalize(direction);
    light.light.intensity = 3.0f;
    light.shadow.technique = "hard";
    light.shadow.required = true;
    light.shadow.setParam("resolution", 2048, "benchmark");
    return light;
}

} // namespace penumbra::bench
