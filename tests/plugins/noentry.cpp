// A shared library with code but without penumbra_plugin_entry: EntryMissing.
#include "penumbra/plugin/Plugin.h"

PENUMBRA_PLUGIN_EXPORT int penumbra_plugin_entry_misspelt() { return 1; }
