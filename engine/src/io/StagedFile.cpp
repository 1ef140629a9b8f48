#include "penumbra/io/StagedFile.h"

#include "penumbra/core/Error.h"

#include <fmt/format.h>
#include <unistd.h>

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

StagedFile::StagedFile(fs::path target) : target_(std::move(target))
{
    checkWritable(target_);
    std::random_device rd;
    temp_ = fs::path(target_).concat(fmt::format(".tmp{:08x}", rd()));
}

StagedFile::~StagedFile()
{
    if (committed_) return;
    std::error_code ec;
    fs::remove(temp_, ec);
}

std::ofstream StagedFile::openTemp() const
{
    std::ofstream out(temp_, std::ios::binary);
    if (!out) {
        throw Error(fmt::format("{}: cannot create the temporary file '{}': {}", target_.string(), temp_.string(),
                                std::strerror(errno)));
    }
    return out;
}

void StagedFile::commit()
{
    std::error_code ec;
    fs::rename(temp_, target_, ec);
    if (ec) {
        throw Error(fmt::format("{}: cannot move the finished file into place: {}", target_.string(), ec.message()));
    }
    committed_ = true;
}

void writeTextFile(const fs::path& path, std::string_view text)
{
    StagedFile file(path);
    std::ofstream out = file.openTemp();
    out.write(text.data(), std::streamsize(text.size()));
    out.close();
    if (!out) throw Error(fmt::format("{}: could not write the file: {}", path.string(), std::strerror(errno)));
    file.commit();
}

} // namespace penumbra::io
