#pragma once
// PNG output that never leaves a half-written file: the image goes to a temporary file
// beside the target, which is renamed over it only once complete.
#include <cstdint>
#include <filesystem>
#include <vector>

namespace penumbra::io {

// Throws Error naming the path when the folder is missing or not writable. Called
// before rendering so that a bad path fails fast.
void checkWritable(const std::filesystem::path& path);

// rgba: width*height*4 bytes, top row first.
void writePng(const std::filesystem::path& path, uint32_t width, uint32_t height, const std::vector<uint8_t>& rgba);

} // namespace penumbra::io
