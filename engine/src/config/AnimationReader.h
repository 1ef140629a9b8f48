#pragma once
// Reading "animation" of a config (config/Animation.cpp): fps and tracks, each target
// checked against the config's lights (a value the light has, aimed one way only), each
// key's value against its target and each key's time against fps (Animation.h's limits).
#include "config/JsonReader.h"
#include "penumbra/config/Animation.h"
#include "penumbra/config/RenderConfig.h"

#include <vector>

namespace penumbra::config {

// The "animation" object of `parent` (the config's root), or no tracks when absent.
// Without tracks it is the frame rate of the glTF animation the scene plays
// (`playsSceneAnimation`), and an error otherwise.
Animation readAnimation(ObjectReader& parent, const std::vector<LightConfig>& lights, bool playsSceneAnimation);

} // namespace penumbra::config
