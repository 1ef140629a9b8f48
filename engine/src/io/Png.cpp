#include "penumbra/io/Png.h"

#include "penumbra/core/Error.h"
#include "penumbra/core/ShortText.h"

#include <fmt/format.h>

#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb/stb_image_write.h>

#include <algorithm>
#include <cctype>

namespace fs = std::filesystem;

namespace penumbra::io {

namespace {

void checkSize(const std::string& name, uint32_t width, uint32_t height, const std::vector<uint8_t>& rgba)
{
    if (width == 0 || height == 0 || rgba.size() != size_t(width) * height * 4) {
        throw Error(fmt::format("{}: {} bytes of pixels for a {}x{} RGBA image", name, rgba.size(), width, height));
    }
}

} // namespace

void writePng(const fs::path& path, uint32_t width, uint32_t height, const std::vector<uint8_t>& rgba)
{
    checkSize(path.string(), width, height, rgba);
    StagedFile file(path);
    if (!stbi_write_png(file.tempPath().c_str(), int(width), int(height), 4, rgba.data(), int(width * 4))) {
        throw Error(fmt::format("{}: cannot write PNG (disk full or permission denied?)", path.string()));
    }
    file.commit();
}

ImageFormat imageFormatFor(const fs::path& path)
{
    std::string extension = path.extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    if (extension == ".png") return ImageFormat::Png;
    if (extension == ".jpg" || extension == ".jpeg") return ImageFormat::Jpeg;
    throw Error(fmt::format("{}: {}; an image is written as .png or .jpg (.jpeg)", core::shortText(path.string()),
                            extension.empty() ? "the name has no extension"
                                              : fmt::format("unknown image extension '{}'", core::shortText(extension))));
}

void writeImage(const fs::path& path, uint32_t width, uint32_t height, const std::vector<uint8_t>& rgba)
{
    if (imageFormatFor(path) == ImageFormat::Png) {
        writePng(path, width, height, rgba);
        return;
    }
    checkSize(path.string(), width, height, rgba);
    StagedFile file(path);
    // Given 4 components, stb's JPEG writer reads RGB and skips the alpha byte.
    constexpr int kJpegQuality = 95;
    if (!stbi_write_jpg(file.tempPath().c_str(), int(width), int(height), 4, rgba.data(), kJpegQuality)) {
        throw Error(fmt::format("{}: cannot write JPEG (disk full or permission denied?)", path.string()));
    }
    file.commit();
}

std::vector<uint8_t> encodePng(const std::string& name, uint32_t width, uint32_t height, const std::vector<uint8_t>& rgba)
{
    checkSize(name, width, height, rgba);
    std::vector<uint8_t> png;
    auto append = [](void* context, void* data, int size) {
        auto* bytes = static_cast<const uint8_t*>(data);
        static_cast<std::vector<uint8_t>*>(context)->insert(static_cast<std::vector<uint8_t>*>(context)->end(), bytes, bytes + size);
    };
    if (!stbi_write_png_to_func(append, &png, int(width), int(height), 4, rgba.data(), int(width * 4))) {
        throw Error(fmt::format("{}: cannot encode the PNG", name));
    }
    return png;
}

} // namespace penumbra::io
