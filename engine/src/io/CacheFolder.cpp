#include "penumbra/io/CacheFolder.h"

#include <cstdlib>

namespace penumbra::io {

std::filesystem::path userCacheFolder()
{
    if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && std::filesystem::path(xdg).is_absolute())
        return std::filesystem::path(xdg) / "penumbra";
    if (const char* home = std::getenv("HOME"); home && std::filesystem::path(home).is_absolute())
        return std::filesystem::path(home) / ".cache" / "penumbra";
    return {};
}

} // namespace penumbra::io
