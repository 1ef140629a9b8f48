// Links libpenumbra_test_absent.so, which the loader cannot find at run time: dlopen fails
// and the registry reports DependencyMissing with the loader's own words.
#include "penumbra/plugin/Plugin.h"

#include <stdexcept>
#include <string>

extern "C" int penumbraTestAbsentValue();

namespace {

penumbra::plugin::Technique* createNodep(const penumbra::plugin::TechniqueSetup&)
{
    throw std::runtime_error("unreachable: the absent library says " + std::to_string(penumbraTestAbsentValue()));
}

} // namespace

PENUMBRA_PLUGIN_EXPORT const PenumbraPluginInfo* penumbra_plugin_entry()
{
    static const PenumbraPluginInfo info{PENUMBRA_PLUGIN_ABI_VERSION, "nodep", "1.0", "links a missing library",
                                         nullptr, 0, &createNodep, nullptr};
    return &info;
}
