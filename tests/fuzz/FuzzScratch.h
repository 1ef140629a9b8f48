#pragma once
// What the fuzz targets share: a scratch folder of the process's own (removed at exit),
// and the input written there as a file, since every target reads files the way a user's
// run does (includes, external buffers, plugin files).
#include <fmt/format.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

namespace penumbra::fuzz {

class ScratchFolder {
public:
    ScratchFolder()
    {
        std::string pattern = (std::filesystem::temp_directory_path() / "penumbra-fuzz-XXXXXX").string();
        if (!::mkdtemp(pattern.data())) {
            std::perror("penumbra fuzz: mkdtemp");
            std::abort();
        }
        path_ = pattern;
    }
    ~ScratchFolder()
    {
        std::error_code ec;
        std::filesystem::remove_all(path_, ec);
    }
    ScratchFolder(const ScratchFolder&) = delete;
    ScratchFolder& operator=(const ScratchFolder&) = delete;
    const std::filesystem::path& path() const { return path_; }

    // Writes `size` bytes to `name` in the folder (replacing it) and returns its path.
    std::filesystem::path write(const std::string& name, const uint8_t* data, size_t size) const
    {
        const std::filesystem::path file = path_ / name;
        std::ofstream out(file, std::ios::binary | std::ios::trunc);
        out.write(reinterpret_cast<const char*>(data), std::streamsize(size));
        if (!out) {
            fmt::print(stderr, "penumbra fuzz: cannot write {}\n", file.string());
            std::abort();
        }
        return file;
    }
    std::filesystem::path write(const std::string& name, const std::string& text) const
    {
        return write(name, reinterpret_cast<const uint8_t*>(text.data()), text.size());
    }

private:
    std::filesystem::path path_;
};

} // namespace penumbra::fuzz
