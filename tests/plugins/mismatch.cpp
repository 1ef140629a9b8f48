// Built as penumbra-mismatch.so but declares the name "other": NameMismatch.
#include "penumbra/plugin/Plugin.h"

namespace {

penumbra::plugin::Technique* createNothing(const penumbra::plugin::TechniqueSetup&) { return nullptr; }

} // namespace

PENUMBRA_PLUGIN_EXPORT const PenumbraPluginInfo* penumbra_plugin_entry()
{
    static const PenumbraPluginInfo info{PENUMBRA_PLUGIN_ABI_VERSION, "other", "1.0", "declares another name",
                                         nullptr, 0, &createNothing, nullptr};
    return &info;
}
