#include "penumbra/plugin/ShadowMapParams.h"

#include "penumbra/core/Error.h"

#include <fmt/format.h>

namespace penumbra::plugin {

float lightSizeOverride(const ParamValues& params, std::string_view technique)
{
    const float size = params.getFloat(kLightSizeParam.name);
    if (size < 0.0f && size != -1.0f) {
        throw ConfigError(fmt::format("{}: {}: -1 (the light's own size) or a size >= 0, got {}", technique,
                                      kLightSizeParam.name, size));
    }
    return size;
}

} // namespace penumbra::plugin
