#pragma once
// What every GPU benchmark shares: one Vulkan context (validation off: it would be
// measured too) and one plugin registry (the build tree's plugins), made on first use and
// kept for the process.
#include "penumbra/config/Config.h"
#include "penumbra/gpu/Context.h"
#include "penumbra/plugin/PluginRegistry.h"

namespace penumbra::bench {

gpu::Context& context();
plugin::PluginRegistry& registry();

// A directional light "sun" towards `direction`, shadowed by `hard` (required) with a
// 2048² map.
config::LightConfig hardSun(glm::vec3 direction);

} // namespace penumbra::bench
