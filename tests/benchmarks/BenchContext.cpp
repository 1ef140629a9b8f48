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

} // namespace penumbra::bench
