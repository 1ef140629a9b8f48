// Built twice, as penumbra-dup.so in two folders of the search path, with versions
// PENUMBRA_TEST_DUP_VERSION 1.0 and 2.0: the first on the path wins, the second is a
// DuplicateName error.
#include "penumbra/plugin/Plugin.h"

namespace {

penumbra::plugin::Technique* createNothing(const penumbra::plugin::TechniqueSetup&) { return nullptr; }

} // namespace

PENUMBRA_PLUGIN_EXPORT const PenumbraPluginInfo* penumbra_plugin_entry()
{
    static const PenumbraPluginInfo info{PENUMBRA_PLUGIN_ABI_VERSION, "dup", PENUMBRA_TEST_DUP_VERSION,
                                         "one name, two files", nullptr, 0, &createNothing, nullptr};
    return &info;
}
