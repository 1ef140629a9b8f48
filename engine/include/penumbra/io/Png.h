#pragma once
// Image output (PNG, JPEG) that never leaves a half-written file (see StagedFile.h).
#include "penumbra/io/StagedFile.h"

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace penumbra::io {

// rgba: width*height*4 bytes, top row first.
void writePng(const std::filesystem::path& path, uint32_t width, uint32_t height, const std::vector<uint8_t>& rgba);

enum class ImageFormat { Png, Jpeg };

// The format a file name asks for: .png, or .jpg/.jpeg (any case); a pattern such as
// "f{frame:04}.png" by the extension it ends in. Throws Error naming the path for any
// other name, so that no file ever holds a format its name does not say.
ImageFormat imageFormatFor(const std::filesystem::path& path);

// Writes `rgba` (as writePng) in the format the file name asks for (imageFormatFor):
// JPEG at quality 95 without the alpha channel, which JPEG cannot hold.
void writeImage(const std::filesystem::path& path, uint32_t width, uint32_t height, const std::vector<uint8_t>& rgba);

// The same PNG as bytes in memory, for containers such as glTF; `name` is for messages.
std::vector<uint8_t> encodePng(const std::string& name, uint32_t width, uint32_t height, const std::vector<uint8_t>& rgba);

} // namespace penumbra::io
