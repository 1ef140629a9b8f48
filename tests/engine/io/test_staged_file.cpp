// io::StagedFile (issue 20, item 5): an output is replaced whole or not at all, a killed
// writer leaves no file under a visible name, and the temporary names a killed writer
// could leave (between naming and rename, or on a file system without O_TMPFILE) are
// removed by the next writer of that target, never a live writer's.
#include "ScratchFolder.h"

#include "penumbra/io/StagedFile.h"

#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <fstream>
#include <set>

using namespace penumbra;
namespace fs = std::filesystem;

namespace {

class StagedFileTest : public test::ScratchFolderTest {
protected:
    std::set<std::string> entries() const { return test::entryNames(dir); }
    static std::string read(const fs::path& file) { return test::readFile(file); }
    void writeFile(const std::string& name, const std::string& text) const
    {
        std::ofstream(dir / name, std::ios::binary) << text;
    }

};

} // namespace

TEST_F(StagedFileTest, ContentIsUnseenUntilTheCommitReplacesTheTargetWhole)
{
    writeFile("out.txt", "old");
    io::StagedFile file(dir / "out.txt");
    {
        std::ofstream out = file.openTemp();
        out << "new content";
    }
    // Written, not committed: the folder shows the old target only (O_TMPFILE: no name at
    // all; without it, one temporary name beside it).
    std::set<std::string> during = entries();
    if (file.unnamed()) {
        EXPECT_EQ(during, std::set<std::string>{"out.txt"});
    } else {
        EXPECT_EQ(during.size(), 2u);
    }
    EXPECT_EQ(read(dir / "out.txt"), "old");
    file.commit();
    EXPECT_EQ(read(dir / "out.txt"), "new content");
    EXPECT_EQ(entries(), std::set<std::string>{"out.txt"});
}

TEST_F(StagedFileTest, AnAbandonedWriteLeavesTheTargetAndNothingElse)
{
    writeFile("out.txt", "old");
    {
        io::StagedFile file(dir / "out.txt");
        file.openTemp() << "half";
    }
    EXPECT_EQ(read(dir / "out.txt"), "old");
    EXPECT_EQ(entries(), std::set<std::string>{"out.txt"});
    // Through the path that stb and OpenEXR open, too.
    {
        io::StagedFile file(dir / "new.txt");
        std::ofstream(file.tempPath(), std::ios::binary) << "half";
    }
    EXPECT_EQ(entries(), std::set<std::string>{"out.txt"});
}

TEST_F(StagedFileTest, TheCommittedFileHasTheModeAnOfstreamWouldGiveIt)
{
    const mode_t old = ::umask(022);
    io::writeTextFile(dir / "out.txt", "x");
    ::umask(old);
    struct stat st {};
    ASSERT_EQ(::stat((dir / "out.txt").c_str(), &st), 0);
    EXPECT_EQ(st.st_mode & 0777, 0644u);
}

TEST_F(StagedFileTest, AWriterKilledWhileWritingLeavesNoFile)
{
    writeFile("out.txt", "old");
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
        io::StagedFile file(dir / "out.txt");
        std::ofstream out = file.openTemp();
        out << std::string(1 << 16, 'x');
        out.flush();
        ::raise(SIGKILL);
        ::_exit(0);
    }
    int status = 0;
    ASSERT_EQ(::waitpid(child, &status, 0), child);
    ASSERT_TRUE(WIFSIGNALED(status));
    EXPECT_EQ(read(dir / "out.txt"), "old");
    // Without O_TMPFILE the killed writer's name stays; the next writer removes it.
    io::writeTextFile(dir / "out.txt", "next");
    EXPECT_EQ(entries(), std::set<std::string>{"out.txt"});
    EXPECT_EQ(read(dir / "out.txt"), "next");
}

TEST_F(StagedFileTest, StaleTemporariesOfTheTargetGoAndALiveWritersStays)
{
    // A killed writer's temporary names (any hex case), a live writer's (held with its
    // flock), and names that are not temporaries of this target.
    for (const char* name : {"out.png.tmp0123abcd", "out.png.tmpDEADBEEF", "out.png.tmplive0000", "out.png.tmp0123",
                             "out.png.tmp0123abcde", "out.png.tmpxyz12345", "other.png.tmp01234567", "out.png.tmp0123abcd.keep"}) {
        writeFile(name, "x");
    }
    fs::rename(dir / "out.png.tmplive0000", dir / "out.png.tmp00001111");
    const int live = ::open((dir / "out.png.tmp00001111").c_str(), O_RDONLY);
    ASSERT_GE(live, 0);
    ASSERT_EQ(::flock(live, LOCK_EX), 0);
    // A link named like a temporary is not followed or removed through.
    fs::create_symlink(dir / "other.png.tmp01234567", dir / "out.png.tmp99999999");

    EXPECT_EQ(io::removeStaleTemporaries(dir / "out.png"), 2);
    EXPECT_EQ(entries(), (std::set<std::string>{"out.png.tmp00001111", "out.png.tmp0123", "out.png.tmp0123abcde",
                                                "out.png.tmpxyz12345", "other.png.tmp01234567", "out.png.tmp0123abcd.keep",
                                                "out.png.tmp99999999"}));
    ::close(live);
    // Its writer gone, the next writer of the target removes it too.
    io::writeTextFile(dir / "out.png", "png");
    EXPECT_FALSE(fs::exists(dir / "out.png.tmp00001111"));
    EXPECT_TRUE(fs::exists(dir / "other.png.tmp01234567"));
}

TEST(StagedFileNames, TemporaryNamesAreTheTargetsNameDotTmpAndEightHexDigits)
{
    EXPECT_TRUE(io::isTemporaryNameOf("a/out.png", "b/out.png.tmp0123abcd"));
    EXPECT_TRUE(io::isTemporaryNameOf("out.png", "out.png.tmpABCDEF09"));
    EXPECT_FALSE(io::isTemporaryNameOf("out.png", "out.png.tmp0123abc"));
    EXPECT_FALSE(io::isTemporaryNameOf("out.png", "out.png.tmp0123abcg"));
    EXPECT_FALSE(io::isTemporaryNameOf("out.png", "xout.png.tmp0123abcd"));
    EXPECT_FALSE(io::isTemporaryNameOf("out.png", "out.png.bak0123abcd"));
    EXPECT_FALSE(io::isTemporaryNameOf("out.png", "out.png"));
}

TEST_F(StagedFileTest, AbandonedEntriesAreRemovedOnlyOfTheKindAskedForAndNeverThroughALinkOrALock)
{
    // Named like leftovers: a folder, a locked folder, a file, a FIFO, a link to a folder.
    const auto leftover = [](const std::string& name) { return name.rfind("stage-", 0) == 0; };
    fs::create_directories(dir / "stage-killed" / "inside");
    writeFile("stage-killed/inside/file", "x");
    fs::create_directory(dir / "stage-live");
    fs::create_directory(dir / "kept");
    writeFile("stage-file", "x");
    ASSERT_EQ(::mkfifo((dir / "stage-fifo").c_str(), 0600), 0);
    fs::create_directory_symlink(dir / "kept", dir / "stage-link");
    const int live = ::open((dir / "stage-live").c_str(), O_RDONLY | O_DIRECTORY);
    ASSERT_GE(live, 0);
    ASSERT_EQ(::flock(live, LOCK_EX), 0);

    EXPECT_EQ(io::removeAbandoned(dir, io::Leftover::Folder, leftover), 1);
    EXPECT_EQ(entries(), (std::set<std::string>{"stage-live", "kept", "stage-file", "stage-fifo", "stage-link"}));
    EXPECT_EQ(io::removeAbandoned(dir, io::Leftover::File, leftover), 1);
    EXPECT_EQ(entries(), (std::set<std::string>{"stage-live", "kept", "stage-fifo", "stage-link"}));
    ::close(live);
    EXPECT_EQ(io::removeAbandoned(dir, io::Leftover::Folder, leftover), 1);
    EXPECT_EQ(entries(), (std::set<std::string>{"kept", "stage-fifo", "stage-link"}));
}
