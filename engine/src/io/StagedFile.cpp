#include "penumbra/io/StagedFile.h"

#include "penumbra/core/Error.h"

#include <fmt/format.h>

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <random>

namespace fs = std::filesystem;

namespace penumbra::io {
namespace {

constexpr std::string_view kTempInfix = ".tmp";
constexpr size_t kTempHexDigits = 8;

fs::path folderOf(const fs::path& path) { return path.has_parent_path() ? path.parent_path() : fs::path("."); }

fs::path randomTemporaryName(const fs::path& target)
{
    static thread_local std::mt19937 random{std::random_device{}()};
    return fs::path(target).concat(fmt::format("{}{:08x}", kTempInfix, uint32_t(random())));
}

} // namespace

void checkWritable(const fs::path& path)
{
    std::error_code ec;
    if (path.empty()) throw Error("output path is empty");
    if (fs::is_directory(path, ec)) {
        throw Error(fmt::format("{}: output path is a directory, expected a file name", path.string()));
    }
    const fs::path dir = folderOf(path);
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

bool isTemporaryNameOf(const fs::path& target, const fs::path& candidate)
{
    const std::string base = target.filename().string();
    const std::string name = candidate.filename().string();
    if (name.size() != base.size() + kTempInfix.size() + kTempHexDigits) return false;
    if (name.compare(0, base.size(), base) != 0 || name.compare(base.size(), kTempInfix.size(), kTempInfix) != 0) return false;
    for (size_t i = base.size() + kTempInfix.size(); i < name.size(); ++i) {
        if (!std::isxdigit(static_cast<unsigned char>(name[i]))) return false;
    }
    return true;
}

int removeAbandoned(const fs::path& folder, Leftover kind, const std::function<bool(const std::string& name)>& isLeftover)
{
    const bool wantFolder = kind == Leftover::Folder;
    int removed = 0;
    std::error_code ec;
    for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
        const fs::path candidate = it->path();
        if (!isLeftover(candidate.filename().string())) continue;
        // O_NOFOLLOW: a link is never opened (nor removed); O_NONBLOCK: a FIFO named like
        // a leftover does not block the open.
        const int fd = ::open(candidate.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC | (wantFolder ? O_DIRECTORY : 0));
        if (fd < 0) continue;
        struct stat opened {}, named {};
        const bool abandoned = ::flock(fd, LOCK_EX | LOCK_NB) == 0 && ::fstat(fd, &opened) == 0 &&
                               (wantFolder ? S_ISDIR(opened.st_mode) : S_ISREG(opened.st_mode)) &&
                               ::lstat(candidate.c_str(), &named) == 0 && named.st_ino == opened.st_ino &&
                               named.st_dev == opened.st_dev;
        if (abandoned) {
            std::error_code removeError;
            if (wantFolder ? fs::remove_all(candidate, removeError) > 0 && !removeError : ::unlink(candidate.c_str()) == 0)
                ++removed;
        }
        ::close(fd);
    }
    return removed;
}

int removeStaleTemporaries(const fs::path& target)
{
    return removeAbandoned(folderOf(target), Leftover::File,
                           [&](const std::string& name) { return isTemporaryNameOf(target, name); });
}

StagedFile::StagedFile(fs::path target) : target_(std::move(target))
{
    checkWritable(target_);
    removeStaleTemporaries(target_);
    // 0666 less the umask, as an ofstream would create the target.
    fd_ = ::open(folderOf(target_).c_str(), O_TMPFILE | O_RDWR | O_CLOEXEC, 0666);
    if (fd_ >= 0) {
        unnamed_ = true;
        writePath_ = fmt::format("/proc/self/fd/{}", fd_);
        // A process without /proc cannot reopen or name the file: write it named instead.
        if (::access(writePath_.c_str(), W_OK) != 0) {
            ::close(fd_);
            fd_ = -1;
            unnamed_ = false;
        }
    }
    if (fd_ < 0) {
        for (int attempt = 0; attempt < 16 && fd_ < 0; ++attempt) {
            named_ = randomTemporaryName(target_);
            fd_ = ::open(named_.c_str(), O_CREAT | O_EXCL | O_RDWR | O_CLOEXEC, 0666);
            if (fd_ < 0 && errno != EEXIST) break;
        }
        if (fd_ < 0) {
            throw Error(fmt::format("{}: cannot create the temporary file '{}': {}", target_.string(), named_.string(),
                                    std::strerror(errno)));
        }
        writePath_ = named_;
    }
    // Marks the file as being written for removeStaleTemporaries in other processes.
    ::flock(fd_, LOCK_EX);
}

StagedFile::~StagedFile()
{
    if (!committed_ && !named_.empty()) {
        std::error_code ec;
        fs::remove(named_, ec);
    }
    if (fd_ >= 0) ::close(fd_);  // an unnamed file vanishes with its last descriptor
}

std::ofstream StagedFile::openTemp() const
{
    std::ofstream out(writePath_, std::ios::binary | std::ios::trunc);
    if (!out) {
        throw Error(fmt::format("{}: cannot write the temporary file '{}': {}", target_.string(), writePath_.string(),
                                std::strerror(errno)));
    }
    return out;
}

void StagedFile::commit()
{
    if (unnamed_) {
        // A name for the finished file (linkat cannot replace the target), then the rename.
        for (int attempt = 0; attempt < 16; ++attempt) {
            named_ = randomTemporaryName(target_);
            if (::linkat(AT_FDCWD, writePath_.c_str(), AT_FDCWD, named_.c_str(), AT_SYMLINK_FOLLOW) == 0) break;
            const int error = errno;
            named_.clear();
            if (error != EEXIST) {
                throw Error(fmt::format("{}: cannot name the finished file: {}", target_.string(), std::strerror(error)));
            }
        }
        if (named_.empty()) throw Error(fmt::format("{}: cannot name the finished file", target_.string()));
    }
    std::error_code ec;
    fs::rename(named_, target_, ec);
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
