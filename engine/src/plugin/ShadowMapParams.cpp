#include "penumbra/plugin/ShadowMapParams.h"

#include "penumbra/core/Error.h"

#include <fmt/format.h>

#include <mutex>
#include <set>
#include <string>

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

namespace {

// "technique/name" of every parameter oddKernelParam checked (techniques are made on the
// viewer's thread and on its comparison worker's).
std::mutex gOddMutex;
std::set<std::string, std::less<>> gOddParams;

} // namespace

int oddKernelParam(const ParamValues& params, std::string_view name, std::string_view technique)
{
    {
        const std::lock_guard lock(gOddMutex);
        gOddParams.insert(fmt::format("{}/{}", technique, name));
    }
    const int kernel = params.getInt(name);
    if (kernel % 2 == 0) {
        throw ConfigError(fmt::format("{}: {}: must be odd (the box is centred on the receiver's texel), got {}; "
                                      "use {} or {}",
                                      technique, name, kernel, kernel - 1, kernel + 1));
    }
    return kernel;
}

bool mustBeOdd(std::string_view technique, std::string_view name)
{
    const std::lock_guard lock(gOddMutex);
    return gOddParams.contains(fmt::format("{}/{}", technique, name));
}

} // namespace penumbra::plugin
