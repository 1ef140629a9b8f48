#pragma once
// PNG output that never leaves a half-written file (see StagedFile.h).
#include "penumbra/io/StagedFile.h"

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace penumbra::io {

// rgba: width*height*4 bytes, top row first.
void writePng(const std::filesystem::path& path, uint32_t width, uint32_t height, const std::vector<uint8_t>& rgba);

// The same PNG as bytes in memory, for containers such as glTF; `name` is for messages.
std::vector<uint8_t> encodePng(const std::string& name, uint32_t width, uint32_t height, const std::vector<uint8_t>& rgba);

} // namespace penumbra::io
