#include "penumbra/io/ReadFile.h"

#include "penumbra/core/ShortText.h"

#include "core/Text.h"

#include <fmt/format.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>

namespace fs = std::filesystem;

namespace penumbra::io {
namespace {

fs::file_type typeOf(mode_t mode)
{
    if (S_ISREG(mode)) return fs::file_type::regular;
    if (S_ISDIR(mode)) return fs::file_type::directory;
    if (S_ISFIFO(mode)) return fs::file_type::fifo;
    if (S_ISSOCK(mode)) return fs::file_type::socket;
    if (S_ISBLK(mode)) return fs::file_type::block;
    if (S_ISCHR(mode)) return fs::file_type::character;
    return fs::file_type::unknown;
}

// "64 MiB" for a whole number of MiB, else "1534 bytes".
std::string bytesText(uint64_t bytes)
{
    constexpr uint64_t kMiB = uint64_t(1) << 20;
    return bytes >= kMiB && bytes % kMiB == 0 ? fmt::format("{} MiB", bytes / kMiB) : fmt::format("{} bytes", bytes);
}

} // namespace

FileReadError::FileReadError(const fs::path& file, FileReadProblem problem, std::string reason)
    : Error(fmt::format("{}: {}", core::shortText(file.string()), reason)), problem_(problem), reason_(std::move(reason))
{
}

RegularFile::RegularFile(const fs::path& file, uint64_t maxBytes, std::string_view what)
    : file_(file), maxBytes_(maxBytes), what_(what)
{
    const auto notRegular = [&](mode_t mode) {
        return FileReadError(file_, FileReadProblem::NotRegular,
                             fmt::format("is {}, expected {} (a regular file)", core::fileTypeName(typeOf(mode)), what_));
    };
    // A FIFO or a device is refused before it is opened (opening one acts: a FIFO's writer
    // wakes, a tape rewinds); the check on the open descriptor below is the one that holds.
    struct stat status{};
    if (::stat(file.c_str(), &status) == 0 && !S_ISREG(status.st_mode)) throw notRegular(status.st_mode);
    fd_ = ::open(file.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
    if (fd_ < 0) {
        const int error = errno;
        struct stat link{};
        if (error == ENOENT) {
            const bool dangling = ::lstat(file.c_str(), &link) == 0 && S_ISLNK(link.st_mode);
            throw FileReadError(file_, FileReadProblem::NotFound, dangling ? "is a dangling link" : "not found");
        }
        throw FileReadError(file_, FileReadProblem::Unreadable, fmt::format("cannot be opened: {}", std::strerror(error)));
    }
    try {
        if (::fstat(fd_, &status) != 0) {
            throw FileReadError(file_, FileReadProblem::Unreadable, fmt::format("cannot be examined: {}", std::strerror(errno)));
        }
        if (!S_ISREG(status.st_mode)) throw notRegular(status.st_mode);
        reportedSize_ = uint64_t(status.st_size);
        if (reportedSize_ > maxBytes_) {
            throw FileReadError(file_, FileReadProblem::TooBig,
                                fmt::format("is {} bytes, more than the {} {} may hold", reportedSize_, bytesText(maxBytes_), what_));
        }
    } catch (...) {
        ::close(fd_);
        throw;
    }
}

RegularFile::~RegularFile() { ::close(fd_); }

fs::path RegularFile::openedPath() const
{
    std::error_code ec;
    fs::path opened = fs::read_symlink(fmt::format("/proc/self/fd/{}", fd_), ec);
    return ec ? fs::path() : opened;
}

size_t RegularFile::readAt(uint64_t offset, void* out, size_t bytes) const
{
    size_t done = 0;
    while (done < bytes) {
        const ssize_t n = ::pread(fd_, static_cast<char*>(out) + done, bytes - done, off_t(offset + done));
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) throw FileReadError(file_, FileReadProblem::Unreadable, fmt::format("cannot be read: {}", std::strerror(errno)));
        if (n == 0) break;
        done += size_t(n);
    }
    return done;
}

std::vector<unsigned char> RegularFile::readAll() const
{
    std::vector<unsigned char> bytes(static_cast<size_t>(reportedSize_));
    const size_t got = readAt(0, bytes.data(), bytes.size());
    if (got < bytes.size()) {  // it shrank since fstat
        bytes.resize(got);
        return bytes;
    }
    // More may follow what fstat reported (a /proc file reports 0 bytes): read on to the
    // end, refusing the first byte beyond the limit.
    std::array<unsigned char, 65536> chunk;
    for (size_t more; (more = readAt(bytes.size(), chunk.data(), chunk.size())) > 0;) {
        if (more > maxBytes_ - bytes.size()) {
            throw FileReadError(file_, FileReadProblem::TooBig,
                                fmt::format("holds more than the {} {} may hold", bytesText(maxBytes_), what_));
        }
        bytes.insert(bytes.end(), chunk.begin(), chunk.begin() + std::ptrdiff_t(more));
    }
    return bytes;
}

std::vector<unsigned char> readRegularFile(const fs::path& file, uint64_t maxBytes, std::string_view what)
{
    return RegularFile(file, maxBytes, what).readAll();
}

std::string readRegularTextFile(const fs::path& file, uint64_t maxBytes, std::string_view what)
{
    const std::vector<unsigned char> bytes = readRegularFile(file, maxBytes, what);
    return {bytes.begin(), bytes.end()};
}

} // namespace penumbra::io
