#pragma once
// Reading a config's "scene": one part's keys, or {"parts": [...]} for several
// (RenderConfig.h: SceneSource). Every error names the file, the JSON path and what is
// expected ("a.json: /scene/parts/1/scale/2: must be in (0, 1e+09], got 0").
#include "config/JsonReader.h"
#include "penumbra/config/RenderConfig.h"

#include <filesystem>

namespace penumbra::config {

// Reads parent's "scene" (the default box-grid when it has none); file paths are resolved
// against `configFile`'s folder and must exist.
SceneSource readScene(ObjectReader& parent, const std::filesystem::path& configFile);

} // namespace penumbra::config
