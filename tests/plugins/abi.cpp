// Built for plugin ABI 9999: AbiMismatch, and no member after abiVersion is read.
#include "penumbra/plugin/Plugin.h"

PENUMBRA_PLUGIN_EXPORT const PenumbraPluginInfo* penumbra_plugin_entry()
{
    static const PenumbraPluginInfo info{9999, "abi", "1.0", "built for another plugin ABI", nullptr, 0, nullptr, nullptr};
    return &info;
}
