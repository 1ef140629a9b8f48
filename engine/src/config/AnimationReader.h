#pragma once
// Reading "animation" of a config (config/Animation.cpp): fps and tracks, each target
// checked against the config's lights and each key's value against its target.
#include "config/JsonReader.h"
#include "penumbra/config/Animation.h"

#include <cstddef>

namespace penumbra::config {

// The "animation" object of `parent` (the config's root), or no tracks when absent.
Animation readAnimation(ObjectReader& parent, size_t lightCount);

} // namespace penumbra::config
