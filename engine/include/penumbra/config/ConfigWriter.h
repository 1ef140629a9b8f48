#pragma once
// A RenderConfig written back as a config file: what the viewer's File > Save writes,
// so that `penumbra render` of the saved file renders what the viewer showed. Every value
// the reader takes is written explicitly (defaults included), so the file does not
// depend on defaults that may change; a sweep or an include of the original is not kept
// (the saved file is the one run the viewer shows).
#include "penumbra/config/RenderConfig.h"

#include <nlohmann/json.hpp>

#include <filesystem>

namespace penumbra::config {

// The config as JSON, as it reads back (parseConfig) into the same RenderConfig. A glTF
// part's path (and its allowed roots) is written relative to `savedAs`'s folder when both
// are on one file-system tree, absolute otherwise. Numbers are written as the shortest
// decimal that reads back to the same float (0.96, not 0.9599999785423279); a part's
// transform, kept in double, as the shortest that reads back to the same double.
nlohmann::json configJson(const RenderConfig& config, const std::filesystem::path& savedAs);

// Its "scene": in the form the config gave (one part's keys, or "parts"), each part with
// its name, source and full transform.
nlohmann::json sceneJson(const SceneSource& source, const std::filesystem::path& savedAs);

// Writes configJson(config, file) to `file` through io::writeTextFile: the file is
// replaced complete or not at all (a crash or kill mid-save leaves the old file).
// Throws Error naming the path.
void saveConfig(const RenderConfig& config, const std::filesystem::path& file);

} // namespace penumbra::config
