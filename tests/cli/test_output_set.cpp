// The output set of `compare -o DIR` and `bench -o DIR` (apps/penumbra/OutputFolder.h,
// issue 20 item 5): DIR holds the whole old set or the whole new one at every moment,
// the user's other files (and links) are kept, and what a killed run leaves is removed by
// the next. Compiled into the unit tests with the CLI's OutputFolder.cpp.
#include "ScratchFolder.h"

#include "OutputFolder.h"

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

// out_: the output set's folder, inside the test's scratch folder.
class OutputSetTest : public test::ScratchFolderTest {
protected:
    void SetUp() override
    {
        test::ScratchFolderTest::SetUp();
        out_ = dir / "out";
    }

    static void put(const fs::path& file, const std::string& text) { std::ofstream(file, std::ios::binary) << text; }
    static std::string read(const fs::path& file) { return test::readFile(file); }
    static std::set<std::string> entries(const fs::path& folder) { return test::entryNames(folder); }
    // A set as bench writes it, with `tag` in every file.
    void writeSet(const app::OutputSet& set, const std::string& tag) const
    {
        for (const char* name : {"results.csv", "results.json", "pareto.svg"}) put(set.folder() / name, tag);
    }
    void expectSet(const std::string& tag) const
    {
        for (const char* name : {"results.csv", "results.json", "pareto.svg"}) EXPECT_EQ(read(out_ / name), tag) << name;
    }

    fs::path out_;
};

} // namespace

TEST_F(OutputSetTest, ANewFolderAppearsWithTheWholeSet)
{
    {
        app::OutputSet set(out_, "-o out");
        writeSet(set, "new");
        EXPECT_FALSE(fs::exists(out_)) << "nothing is visible before the commit";
        EXPECT_TRUE(set.commit());
    }
    expectSet("new");
    EXPECT_EQ(entries(dir), std::set<std::string>{"out"}) << "no staging folder is left";
}

TEST_F(OutputSetTest, TheSetIsReplacedAtOnceAndTheUsersFilesAndLinksStay)
{
    fs::create_directory(out_);
    put(out_ / "results.csv", "old");
    put(out_ / "results.json", "old");
    put(out_ / "pareto.svg", "old");
    put(out_ / "notes.txt", "mine");
    fs::create_symlink("notes.txt", out_ / "notes.link");
    fs::create_symlink("/nonexistent/penumbra", out_ / "dangling.link");
    ::chmod(out_.c_str(), 0750);
    struct stat before {};
    ASSERT_EQ(::stat((out_ / "notes.txt").c_str(), &before), 0);
    {
        app::OutputSet set(out_, "-o out");
        writeSet(set, "new");
        expectSet("old");
        EXPECT_TRUE(set.commit()) << "replaced at once";
    }
    expectSet("new");
    EXPECT_EQ(entries(out_), (std::set<std::string>{"results.csv", "results.json", "pareto.svg", "notes.txt", "notes.link",
                                                    "dangling.link"}));
    struct stat after {};
    ASSERT_EQ(::stat((out_ / "notes.txt").c_str(), &after), 0);
    EXPECT_EQ(after.st_ino, before.st_ino) << "the user's file is the same file, not a copy";
    EXPECT_EQ(read(out_ / "notes.txt"), "mine");
    EXPECT_TRUE(fs::is_symlink(out_ / "notes.link"));
    EXPECT_EQ(fs::read_symlink(out_ / "dangling.link"), "/nonexistent/penumbra");
    struct stat folder {};
    ASSERT_EQ(::stat(out_.c_str(), &folder), 0);
    EXPECT_EQ(folder.st_mode & 0777, 0750u) << "the folder keeps its mode";
    EXPECT_EQ(entries(dir), std::set<std::string>{"out"});
}

TEST_F(OutputSetTest, ALinkToTheFolderStaysALinkAndItsTargetGetsTheSet)
{
    fs::create_directory(dir / "real");
    put(dir / "real" / "notes.txt", "mine");
    fs::create_directory_symlink("real", out_);
    {
        app::OutputSet set(out_, "-o out");
        writeSet(set, "new");
        EXPECT_TRUE(set.commit());
    }
    EXPECT_TRUE(fs::is_symlink(out_));
    expectSet("new");
    EXPECT_EQ(read(dir / "real" / "notes.txt"), "mine");
    EXPECT_EQ(entries(dir), (std::set<std::string>{"out", "real"}));
}

TEST_F(OutputSetTest, AFolderInsideIsKeptAndTheFilesAreMovedOneByOne)
{
    fs::create_directories(out_ / "plots");
    put(out_ / "plots" / "mine.svg", "mine");
    put(out_ / "results.csv", "old");
    {
        app::OutputSet set(out_, "-o out");
        writeSet(set, "new");
        EXPECT_FALSE(set.commit()) << "a folder cannot be hard-linked: one by one";
    }
    expectSet("new");
    EXPECT_EQ(read(out_ / "plots" / "mine.svg"), "mine");
    EXPECT_EQ(entries(dir), std::set<std::string>{"out"});
}

TEST_F(OutputSetTest, TheWorkingFolderIsNotExchangedUnderTheShellInIt)
{
    // `-o .` (or a folder above the working one): exchanging it would leave the process,
    // and a shell in it, in the removed old folder; its files move one by one.
    fs::create_directories(out_);
    put(out_ / "results.csv", "old");
    const fs::path before = fs::current_path();
    for (const fs::path& cwd : {out_, out_ / "sub"}) {
        fs::create_directories(cwd);
        fs::current_path(cwd);
        bool exchanged = true;
        {
            app::OutputSet set(out_, "-o .");
            writeSet(set, "new");
            exchanged = set.commit();
        }
        const bool stillThere = fs::exists(fs::current_path() / ".");
        fs::current_path(before);
        EXPECT_FALSE(exchanged) << cwd;
        EXPECT_TRUE(stillThere);
        expectSet("new");
        EXPECT_EQ(entries(dir), std::set<std::string>{"out"});
    }
}

TEST_F(OutputSetTest, ARunKilledBeforeTheCommitLeavesTheOldSetAndTheNextRunClearsItsStage)
{
    fs::create_directory(out_);
    put(out_ / "results.csv", "old");
    put(out_ / "results.json", "old");
    put(out_ / "pareto.svg", "old");
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
        app::OutputSet set(out_, "-o out");
        writeSet(set, "killed");
        ::raise(SIGKILL);
        ::_exit(0);
    }
    int status = 0;
    ASSERT_EQ(::waitpid(child, &status, 0), child);
    ASSERT_TRUE(WIFSIGNALED(status));
    expectSet("old");
    EXPECT_EQ(entries(dir).size(), 2u) << "the killed run's hidden staging folder";
    {
        app::OutputSet set(out_, "-o out");
        writeSet(set, "new");
        EXPECT_TRUE(set.commit());
    }
    expectSet("new");
    EXPECT_EQ(entries(dir), std::set<std::string>{"out"});
}

TEST_F(OutputSetTest, OnlyStagesNoLiveRunHoldsAreStale)
{
    fs::create_directory(out_);
    for (const char* name : {".out.penumbra-abc123", ".out.penumbra-live00", ".out.penumbra-toolong1", ".other.penumbra-abc123"}) {
        fs::create_directory(dir / name);
        put(dir / name / "results.csv", "x");
    }
    const int live = ::open((dir / ".out.penumbra-live00").c_str(), O_RDONLY | O_DIRECTORY);
    ASSERT_GE(live, 0);
    ASSERT_EQ(::flock(live, LOCK_EX), 0);
    EXPECT_EQ(app::removeStaleOutputStages(out_), 1);
    EXPECT_EQ(entries(dir), (std::set<std::string>{"out", ".out.penumbra-live00", ".out.penumbra-toolong1",
                                                     ".other.penumbra-abc123"}));
    ::close(live);
    EXPECT_EQ(app::removeStaleOutputStages(dir / "out/"), 1) << "\"out/\" names the same folder";
}

TEST_F(OutputSetTest, AnAbandonedSetLeavesNothing)
{
    fs::create_directory(out_);
    put(out_ / "results.csv", "old");
    {
        app::OutputSet set(out_, "-o out");
        writeSet(set, "new");
    }
    EXPECT_EQ(read(out_ / "results.csv"), "old");
    EXPECT_EQ(entries(dir), std::set<std::string>{"out"});
    EXPECT_EQ(entries(out_), std::set<std::string>{"results.csv"});
}

TEST(OutputFolders, SameFolderResolvesLinksAndTrailingSlashes)
{
    const fs::path root = test::makeScratchFolder("samefolder");
    fs::create_directory(root / "real");
    fs::create_directory_symlink("real", root / "link");
    EXPECT_TRUE(app::sameFolder(root / "real", root / "link"));
    EXPECT_TRUE(app::sameFolder(root / "real/", root / "real"));
    EXPECT_TRUE(app::sameFolder(root / "missing", root / "missing/"));
    EXPECT_FALSE(app::sameFolder(root / "real", root / "missing"));
    fs::remove_all(root);
}
