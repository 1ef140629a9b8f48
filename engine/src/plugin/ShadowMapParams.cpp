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

int oddKernelParam(const ParamValues& params, std::string_view name, std::string_view technique)
{
    const int kernel = params.getInt(name);
    if (kernel % 2 == 0) {
        throw ConfigError(fmt::format("{}: {}: must be odd (the box is centred on the receiver's texel), got {}; "
                                      "use {} or {}",
                                      technique, name, kernel, kernel - 1, kernel + 1));
    }
    return kernel;
}

} // namespace penumbra::plugin
