#include "penumbra/io/Png.h"

#include "penumbra/core/Error.h"

#include <fmt/format.h>
#include <unistd.h>

#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb/stb_image_write.h>

#include <cerrno>
#include <cstring>
#include <random>

namespace fs = std::filesystem;

namespace penumbra::io {

void checkWritable(const fs::path& path)
{
    std::error_code ec;
    if (path.empty()) throw Error("output path is empty");
    if (fs::is_directory(path, ec)) {
        throw Error(fmt::format("{}: output path is a directory, expected a file name", path.string()));
    }
    const fs::path dir = path.has_parent_path() ? path.parent_path() : fs::path(".");
    if (!fs::is_directory(dir, ec)) {
        throw Error(fmt::format("{}: output folder '{}' does not exist", path.string(), dir.string()));
    }
    if (::access(dir.c_str(), W_OK) != 0) {
        throw Error(fmt::format("{}: output folder '{}' is not writable: {}", path.string(), dir.string(),
                                std::strerror(errno)));
    }
    if (fs::exists(path, ec) && ::access(path.c_str(), W_OK) != 0) {
        throw Error(fmt::format("{}: output file exists and is not writable: {}", path.string(), std::strerror(errno)));
    }
}

void writePng(const fs::path& path, uint32_t width, uint32_t height, const std::vector<uint8_t>& rgba)
{
    if (rgba.size() != size_t(width) * height * 4) {
        throw Error(fmt::format("{}: {} bytes of pixels for a {}x{} RGBA image", path.string(), rgba.size(), width, height));
    }
    checkWritable(path);
    std::random_device rd;
    const fs::path temp = fs::path(path).concat(fmt::format(".tmp{:08x}", rd()));
    const int ok = stbi_write_png(temp.c_str(), int(width), int(height), 4, rgba.data(), int(width * 4));
    std::error_code ec;
    if (!ok) {
        fs::remove(temp, ec);
        throw Error(fmt::format("{}: cannot write PNG (disk full or permission denied?)", path.string()));
    }
    fs::rename(temp, path, ec);
    if (ec) {
        fs::remove(temp, ec);
        throw Error(fmt::format("{}: cannot move the finished PNG into place: {}", path.string(), ec.message()));
    }
}

} // namespace penumbra::io
