// A factory that fails as its `behaviour` parameter says: throws penumbra::Error, throws
// something that is not a std::exception, or returns null. Each is RegistrationFailed.
#include "penumbra/core/Error.h"
#include "penumbra/plugin/Plugin.h"
#include "penumbra/plugin/Technique.h"

#include <iterator>

namespace {

using namespace penumbra;

const char* const kBehaviours[] = {"throw", "throw_int", "return_null"};
const plugin::ParamSpec kParams[] = {
    {"behaviour", plugin::ParamType::Enum, 0, 0, 0, "", "how the factory fails", kBehaviours, std::size(kBehaviours)},
};

plugin::Technique* createThrows(const plugin::TechniqueSetup& setup)
{
    const std::string_view behaviour = setup.params.getEnum("behaviour");
    if (behaviour == "throw_int") throw 42;
    if (behaviour == "return_null") return nullptr;
    throw Error("shader throws/visibility.comp: not found");
}

} // namespace

PENUMBRA_PLUGIN_EXPORT const PenumbraPluginInfo* penumbra_plugin_entry()
{
    static const PenumbraPluginInfo info{PENUMBRA_PLUGIN_ABI_VERSION, "throws", "1.0", "a factory that fails",
                                         kParams, std::size(kParams), &createThrows, nullptr};
    return &info;
}
