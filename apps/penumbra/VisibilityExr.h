#pragma once
// Float output of the visibility images V_l, for users' own analysis: one OpenEXR file
// (scan lines, ZIP), one 32-bit FLOAT channel per light named "<light name>.V", rows top
// first as the images are; V exactly as the technique (or the reference) wrote it, so
// values outside [0, 1] or non-finite ones show. Written through io::StagedFile: a file
// appears complete or not at all.
#include "penumbra/config/RenderConfig.h"

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace penumbra::app {

// "sun" -> "sun.V": the channel of a light's V in the files below.
std::string visibilityChannel(const std::string& lightName);

// `visibility[i]` is light `lights[i]`'s V. Throws Error naming `path` when it cannot be
// written, or when the images do not match width x height or the lights.
void writeVisibilityExr(const std::filesystem::path& path, uint32_t width, uint32_t height,
                        const std::vector<config::LightConfig>& lights, const std::vector<std::vector<float>>& visibility);

} // namespace penumbra::app
