#pragma once
// Reading "animation" of a config (config/Animation.cpp): fps and tracks, each target
// checked against the config's lights (a value the light has, aimed one way only) and
// each key's value against its target.
#include "config/JsonReader.h"
#include "penumbra/config/Animation.h"
#include "penumbra/config/RenderConfig.h"

#include <vector>

namespace penumbra::config {

// The "animation" object of `parent` (the config's root), or no tracks when absent.
Animation readAnimation(ObjectReader& parent, const std::vector<LightConfig>& lights);

} // namespace penumbra::config
