#pragma once
// The visibility images V_l as 32-bit float OpenEXR files, for users' own analysis and for
// `penumbra compare A.exr B.exr`. One file (scan lines, ZIP), rows top first as the
// images are, holds:
//   - "<light name>.V" per light: V exactly as the technique (or the reference) wrote it,
//     so values outside [0, 1] or non-finite ones show; and
//   - "Y": the first light's V once more. Readers that show an image's luminance or RGB
//     only (ImageMagick, OpenCV, most image viewers) see no other channel; with Y they
//     show the first light's V as grey, where they would show zeros or nothing.
// Written through io::StagedFile: a file appears complete or not at all.
#include "penumbra/config/RenderConfig.h"
#include "penumbra/metrics/ImageComparison.h"

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace penumbra::app {

// "sun" -> "sun.V": the channel of a light's V in the files below.
std::string visibilityChannel(const std::string& lightName);
// The first light's V again, under the name luminance-only readers look for.
inline constexpr const char* kFirstLightLumaChannel = "Y";

// `visibility[i]` is light `lights[i]`'s V. Throws Error naming `path` when it cannot be
// written, or when the images do not match width x height or the lights.
void writeVisibilityExr(const std::filesystem::path& path, uint32_t width, uint32_t height,
                        const std::vector<config::LightConfig>& lights, const std::vector<std::vector<float>>& visibility);

// Every channel of an OpenEXR file, as 32-bit floats (a HALF or UINT channel converted).
struct ExrImage {
    uint32_t width = 0;
    uint32_t height = 0;
    struct Channel {
        std::string name;
        std::vector<float> values;  // width * height, rows top first
    };
    std::vector<Channel> channels;  // in the file's order (by name)
};

// The largest file and image readExr takes: 1 GiB of file, 65536 pixels a side, 2^28
// values in all.
inline constexpr uint64_t kMaxExrFileBytes = uint64_t(1) << 30;
inline constexpr uint32_t kMaxExrSide = 65536;
inline constexpr uint64_t kMaxExrValues = uint64_t(1) << 28;

// Reads the first part of `path` over its data window. Throws Error naming the file when it
// cannot be read (missing, not a regular file, beyond the limits) or is no OpenEXR image.
ExrImage readExr(const std::filesystem::path& path);

// Each channel of `test` against its namesake in `reference` (metrics::compareVisibility
// over every pixel: the files hold no geometry mask).
struct ExrChannelComparison {
    std::string channel;
    metrics::VisibilityComparison visibility;
};
// Throws Error naming both files when their sizes or their channels' names differ.
std::vector<ExrChannelComparison> compareExrChannels(const ExrImage& test, const std::filesystem::path& testPath,
                                                     const ExrImage& reference, const std::filesystem::path& referencePath);

} // namespace penumbra::app
