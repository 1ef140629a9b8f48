#include "penumbra/io/Png.h"

#include "penumbra/core/Error.h"

#include <fmt/format.h>

#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb/stb_image_write.h>

namespace fs = std::filesystem;

namespace penumbra::io {

void writePng(const fs::path& path, uint32_t width, uint32_t height, const std::vector<uint8_t>& rgba)
{
    if (rgba.size() != size_t(width) * height * 4) {
        throw Error(fmt::format("{}: {} bytes of pixels for a {}x{} RGBA image", path.string(), rgba.size(), width, height));
    }
    StagedFile file(path);
    if (!stbi_write_png(file.tempPath().c_str(), int(width), int(height), 4, rgba.data(), int(width * 4))) {
        throw Error(fmt::format("{}: cannot write PNG (disk full or permission denied?)", path.string()));
    }
    file.commit();
}

} // namespace penumbra::io
