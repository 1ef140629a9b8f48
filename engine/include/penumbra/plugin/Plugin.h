#pragma once
// The plugin ABI: what a shadow-technique shared library exports. One C symbol,
// `penumbra_plugin_entry`, returns a static PenumbraPluginInfo whose first member is the
// ABI version the plugin was built against; the engine reads that member before it
// touches anything else and refuses the plugin when it differs from its own. The rest
// (name, version, summary, reflected parameters, factory) is read only after the check.
//
// Plugins are C++ and share the engine's C++ types (they are built against these headers
// with the same compiler), so the ABI version is raised whenever any public engine header
// changes a type that crosses the boundary. A plugin defines its entry point with one
// line (docs/plugins.md):
//
//   PENUMBRA_DEFINE_PLUGIN("mine", "1.0.0", "what it does", kParams, MineShadow)
#include <cstdint>
#include <iterator>

#define PENUMBRA_PLUGIN_ABI_VERSION 14u
#define PENUMBRA_PLUGIN_ENTRY_SYMBOL "penumbra_plugin_entry"
#define PENUMBRA_PLUGIN_EXPORT extern "C" __attribute__((visibility("default")))

namespace penumbra::plugin {

class Technique;
struct TechniqueSetup;

enum class ParamType : uint32_t { Bool, Int, Float, Enum };

// One reflected parameter. Plain data with static storage in the plugin, so that the
// engine can list parameters (`penumbra plugins`) without creating a technique.
struct ParamSpec {
    const char* name;       // snake_case, unique in the plugin: "pcf_kernel"
    ParamType type;
    double defaultValue;    // Bool: 0/1; Enum: index into choices
    double minValue;        // Int/Float: inclusive range; ignored for Bool/Enum
    double maxValue;
    const char* unit;       // "texels", "world", "" when unitless
    const char* doc;        // one line
    const char* const* choices = nullptr;  // Enum only
    uint32_t choiceCount = 0;
    // Int only: odd values only (a box of taps centred on the receiver's texel has no
    // centre when even); min, default and max must be odd too. An even value is refused
    // where it is set, and an editor offers the odd values only.
    bool odd = false;
};

// Creates a technique for one light. May throw penumbra::Error (bad parameters, a
// shader that does not compile): the engine reports it as an exception during
// registration, naming the plugin and the light.
using CreateTechniqueFn = Technique* (*)(const TechniqueSetup& setup);

// The factory of PENUMBRA_DEFINE_PLUGIN: a `T` (a Technique) constructed from the setup.
template <class T>
Technique* createTechnique(const TechniqueSetup& setup)
{
    return new T(setup);
}

} // namespace penumbra::plugin

extern "C" {

struct PenumbraPluginInfo {
    uint32_t abiVersion;  // first, and never moved: PENUMBRA_PLUGIN_ABI_VERSION
    const char* name;     // the technique name configs use: "hard"
    const char* version;  // the plugin's own version: "1.2.0"
    const char* summary;  // one line
    const penumbra::plugin::ParamSpec* params;
    uint32_t paramCount;
    penumbra::plugin::CreateTechniqueFn create;
    // Where the plugin's GLSL lives when built (absolute; the CMake helper
    // penumbra_add_plugin defines PENUMBRA_PLUGIN_SHADER_DIR). When that folder does not
    // exist (an installed plugin), the engine looks in <plugin file's folder>/<name>/.
    const char* shaderDir;
};

using PenumbraPluginEntryFn = const PenumbraPluginInfo* (*)();

} // extern "C"

// Where a plugin built with penumbra_add_plugin finds its GLSL when built: that helper
// defines it in a generated file of its own and PENUMBRA_PLUGIN_SHADER_DIR as a call to it
// (the absolute path then stays off the plugin's other compile lines). A plugin built
// without the helper defines PENUMBRA_PLUGIN_SHADER_DIR as a string itself.
const char* penumbra_plugin_shader_dir();

// Defines the plugin's entry point, penumbra_plugin_entry, returning a static
// PenumbraPluginInfo: this ABI version, the name (configs' "technique"; the file is
// penumbra-<name>.so), the plugin's version, a one-line summary, the ParamSpec array
// `params`, a factory that constructs `TechniqueClass` from the TechniqueSetup (a
// constructor may throw penumbra::Error: an unsupported light, a bad parameter), and
// PENUMBRA_PLUGIN_SHADER_DIR (penumbra_add_plugin defines it). Use it once, at global
// scope:
//
//   PENUMBRA_DEFINE_PLUGIN("hard", "1.0.0", "shadow map with ...", kParams, penumbra::hard::HardShadow)
#define PENUMBRA_DEFINE_PLUGIN(name, version, summary, params, TechniqueClass)                                    \
    PENUMBRA_DEFINE_PLUGIN_FACTORY(name, version, summary, params, &::penumbra::plugin::createTechnique<TechniqueClass>)

// The same with a factory of the plugin's own (a CreateTechniqueFn), for a plugin that
// picks its Technique class per light.
#define PENUMBRA_DEFINE_PLUGIN_FACTORY(name, version, summary, params, factory)                                   \
    PENUMBRA_PLUGIN_EXPORT const PenumbraPluginInfo* penumbra_plugin_entry()                                     \
    {                                                                                                            \
        static const PenumbraPluginInfo info{PENUMBRA_PLUGIN_ABI_VERSION,                                        \
                                             name,                                                               \
                                             version,                                                            \
                                             summary,                                                            \
                                             std::data(params),                                                  \
                                             uint32_t(std::size(params)),                                        \
                                             factory,                                                            \
                                             PENUMBRA_PLUGIN_SHADER_DIR};                                        \
        return &info;                                                                                            \
    }
