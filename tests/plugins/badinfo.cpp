// A parameter whose default lies outside its range: InvalidInfo.
#include "penumbra/plugin/Plugin.h"

#include <iterator>

namespace {

using namespace penumbra;

const plugin::ParamSpec kParams[] = {
    {"kernel", plugin::ParamType::Int, 20, 1, 15, "texels", "default outside its range"},
};

plugin::Technique* createNothing(const plugin::TechniqueSetup&) { return nullptr; }

} // namespace

PENUMBRA_PLUGIN_EXPORT const PenumbraPluginInfo* penumbra_plugin_entry()
{
    static const PenumbraPluginInfo info{PENUMBRA_PLUGIN_ABI_VERSION, "badinfo", "1.0", "a malformed parameter spec",
                                         kParams, std::size(kParams), &createNothing, nullptr};
    return &info;
}
