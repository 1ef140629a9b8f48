#pragma once
// Reading an input file, the one way the engine reads every file it is given: configs and
// their includes, glTF files with their buffers and images, shaders and their #includes,
// plugin files. The file is opened once (O_NONBLOCK, so a FIFO cannot block the open)
// and checked on the open descriptor, so nothing can swap it between check and read: it
// must be a regular file once links are followed, and hold at most a limit the caller
// sets. The size fstat reports is only a first guess: a /proc file says 0 bytes and
// holds more (or cannot be read at all: /proc/self/mem), a file being written grows, so
// the read goes on to the end of the file and stops one byte past the limit.
#include "penumbra/core/Error.h"

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra::io {

enum class FileReadProblem {
    NotFound,    // no such file, or a link to none
    NotRegular,  // a directory, a FIFO, a socket, a device
    TooBig,      // beyond the caller's limit
    Unreadable,  // the system refused to open or read it (permissions, EIO, a name too long)
};

// Why a file could not be read. reason() says it without the file's name ("is a FIFO
// (named pipe), expected a glTF buffer (a regular file)"), for a caller that rethrows it
// as its own error type with its own context; what() is "<file, shortened>: <reason>".
class FileReadError : public Error {
public:
    FileReadError(const std::filesystem::path& file, FileReadProblem problem, std::string reason);
    FileReadProblem problem() const { return problem_; }
    const std::string& reason() const { return reason_; }

private:
    FileReadProblem problem_;
    std::string reason_;
};

// An input file, open for reading. `what` names the kind of file expected, for the
// reasons ("a JSON config file": "... expected a JSON config file (a regular file)",
// "is 70000000 bytes, more than the 64 MiB a JSON config file may hold").
class RegularFile {
public:
    // Throws FileReadError when `file` is missing, not a regular file (after following
    // links), cannot be opened, or reports more than `maxBytes` bytes.
    RegularFile(const std::filesystem::path& file, uint64_t maxBytes, std::string_view what);
    ~RegularFile();
    RegularFile(const RegularFile&) = delete;
    RegularFile& operator=(const RegularFile&) = delete;

    // The size fstat reported when it was opened (0 for a /proc file).
    uint64_t reportedSize() const { return reportedSize_; }
    // Reads up to `bytes` bytes at `offset` into `out`; returns how many were read (fewer
    // only at the end of the file). Throws FileReadError when the system refuses.
    size_t readAt(uint64_t offset, void* out, size_t bytes) const;
    // The whole file. Throws FileReadError when it holds more than the limit.
    std::vector<unsigned char> readAll() const;
    // The file the open descriptor reads, absolute with every link resolved as the open
    // resolved it (/proc/self/fd): what a confinement check must look at, since the path
    // given may have been swapped for a link between that check and the open. Empty where
    // /proc is not mounted.
    std::filesystem::path openedPath() const;

private:
    std::filesystem::path file_;
    uint64_t maxBytes_;
    std::string what_;
    int fd_ = -1;
    uint64_t reportedSize_ = 0;
};

// The whole of `file`, checked and read as RegularFile does.
std::vector<unsigned char> readRegularFile(const std::filesystem::path& file, uint64_t maxBytes, std::string_view what);
std::string readRegularTextFile(const std::filesystem::path& file, uint64_t maxBytes, std::string_view what);

} // namespace penumbra::io
