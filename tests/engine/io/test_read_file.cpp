// io::RegularFile (io/ReadFile.h), the one way the engine reads an input file: only a
// regular file, never waited on, never read past its limit, whatever size fstat reports.
// What each caller makes of it is tested with the caller (configs, glTF, shaders, plugins).
#include "ScratchFolder.h"

#include "penumbra/io/ReadFile.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <fstream>

using namespace penumbra;
namespace fs = std::filesystem;

namespace {

class ReadFile : public test::ScratchFolderTest {
protected:
    // The FileReadError reading `file` within `maxBytes` gives; a test failure if it reads.
    static io::FileReadError refusal(const fs::path& file, uint64_t maxBytes = 1024)
    {
        try {
            io::readRegularFile(file, maxBytes, "a test file");
        } catch (const io::FileReadError& e) {
            return e;
        }
        ADD_FAILURE() << file << " was read";
        return io::FileReadError(file, io::FileReadProblem::Unreadable, "");
    }

};

} // namespace

TEST_F(ReadFile, OnlyRegularFilesAreRead)
{
    ASSERT_EQ(::mkfifo((dir / "pipe").c_str(), 0600), 0);  // no writer: an open without O_NONBLOCK would wait
    io::FileReadError e = refusal(dir / "pipe");
    EXPECT_EQ(e.problem(), io::FileReadProblem::NotRegular);
    EXPECT_EQ(e.reason(), "is a FIFO (named pipe), expected a test file (a regular file)");
    EXPECT_NE(std::string(e.what()).find("/pipe: is a FIFO"), std::string::npos) << e.what();
    EXPECT_EQ(refusal("/dev/zero").reason(), "is a character device, expected a test file (a regular file)");
    EXPECT_EQ(refusal(dir).problem(), io::FileReadProblem::NotRegular);
    fs::create_symlink(dir / "pipe", dir / "to_pipe");  // links are followed
    EXPECT_EQ(refusal(dir / "to_pipe").problem(), io::FileReadProblem::NotRegular);
    fs::create_symlink(dir / "nowhere", dir / "dangling");
    e = refusal(dir / "dangling");
    EXPECT_EQ(e.problem(), io::FileReadProblem::NotFound);
    EXPECT_EQ(e.reason(), "is a dangling link");
    EXPECT_EQ(refusal(dir / "missing").reason(), "not found");
}

TEST_F(ReadFile, TheLimitHoldsWhateverFstatSays)
{
    std::ofstream(dir / "ten") << "0123456789";
    EXPECT_EQ(io::readRegularTextFile(dir / "ten", 10, "a test file"), "0123456789");
    io::FileReadError e = refusal(dir / "ten", 9);
    EXPECT_EQ(e.problem(), io::FileReadProblem::TooBig);
    EXPECT_EQ(e.reason(), "is 10 bytes, more than the 9 bytes a test file may hold");
    // /proc files report 0 bytes: read to their end, and refused one byte past the limit.
    const io::RegularFile status("/proc/self/status", 1 << 20, "a test file");
    EXPECT_EQ(status.reportedSize(), 0u);
    const std::vector<unsigned char> text = status.readAll();
    EXPECT_EQ(std::string(text.begin(), text.begin() + 5), "Name:");
    e = refusal("/proc/self/status", 16);
    EXPECT_EQ(e.problem(), io::FileReadProblem::TooBig);
    EXPECT_EQ(e.reason(), "holds more than the 16 bytes a test file may hold");
    // /proc/self/mem cannot be read at its start: an error, not an exception of another kind.
    e = refusal("/proc/self/mem");
    EXPECT_EQ(e.problem(), io::FileReadProblem::Unreadable);
    EXPECT_EQ(e.reason(), "cannot be read: Input/output error");
}

TEST_F(ReadFile, ReadsAtAnOffsetFewerAtTheEnd)
{
    std::ofstream(dir / "ten") << "0123456789";
    const io::RegularFile file(dir / "ten", 10, "a test file");
    char bytes[8] = {};
    EXPECT_EQ(file.readAt(6, bytes, sizeof bytes), 4u);
    EXPECT_EQ(std::string(bytes, 4), "6789");
    EXPECT_EQ(file.readAt(10, bytes, sizeof bytes), 0u);
}

// The open descriptor names the file it reached, links and all: a link (in the file's
// place or in a folder on its way) leads a confinement check to the real file.
TEST_F(ReadFile, TheOpenedPathIsTheFileTheOpenReached)
{
    fs::create_directories(dir / "inside");
    fs::create_directories(dir / "outside");
    std::ofstream(dir / "outside/secret") << "s";
    std::ofstream(dir / "inside/plain") << "p";
    fs::create_symlink(dir / "outside/secret", dir / "inside/link");
    fs::create_directory_symlink(dir / "outside", dir / "inside/folder");
    const fs::path real = fs::canonical(dir);
    EXPECT_EQ(io::RegularFile(dir / "inside/plain", 16, "a test file").openedPath(), real / "inside/plain");
    EXPECT_EQ(io::RegularFile(dir / "inside/link", 16, "a test file").openedPath(), real / "outside/secret");
    EXPECT_EQ(io::RegularFile(dir / "inside/folder/secret", 16, "a test file").openedPath(), real / "outside/secret");
}
