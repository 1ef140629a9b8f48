#pragma once
// `-o DIR` of the commands that write a set of files (compare, bench), and the folder of
// `bench --summary FILE`: "out/" names the folder "out"; it is created when missing (its
// parent must exist), once the run has succeeded; files in it that are not the command's
// are left alone.
//
// The set is all or nothing (OutputSet): its files are written into a staging folder
// beside DIR, which then takes DIR's place in one atomic exchange (renameat2
// RENAME_EXCHANGE), the user's other files hard-linked into it first. A run killed at any
// moment leaves DIR with the whole old set or the whole new one, never a mix; the hidden
// staging folder it may leave (.DIR.penumbra-XXXXXX) is removed by the next run that
// writes to DIR. Where the exchange cannot keep the user's files (DIR holds a folder, is
// the working folder or one above it, or the file system refuses hard links or the
// exchange) the files are moved in one by one, each atomically, with a warning.
#include <filesystem>
#include <string>
#include <vector>

namespace penumbra::app {

// The folder that `-o` names ("out/" and "out" alike).
std::filesystem::path outputFolder(const std::string& flag);

// Fails (penumbra::Error naming `who`: "-o out") before any work when the folder cannot be
// created, or exists and one of `files` in it could not be written.
void checkOutputFolder(const std::filesystem::path& dir, const std::vector<std::filesystem::path>& files,
                       const std::string& who);

// Creates the folder when missing (checkOutputFolder said that it can be).
void createOutputFolder(const std::filesystem::path& dir, const std::string& who);

// Whether `a` and `b` name one folder (links resolved; either may not exist yet).
bool sameFolder(const std::filesystem::path& a, const std::filesystem::path& b);

class OutputSet {
public:
    // Creates the staging folder for `dir` (removing those killed runs left). Throws
    // penumbra::Error naming `who` when it cannot.
    OutputSet(std::filesystem::path dir, std::string who);
    // Removes the staging folder unless commit() put it in place.
    ~OutputSet();
    OutputSet(const OutputSet&) = delete;
    OutputSet& operator=(const OutputSet&) = delete;

    // Where to write the set's files: `dir` in the file names the command checked becomes
    // this folder.
    const std::filesystem::path& folder() const { return stage_; }
    // Puts every file written into folder() into `dir` at once (see above). Returns false
    // when it had to move them one by one (it says why in a warning).
    bool commit();

private:
    std::filesystem::path dir_;    // as given
    std::filesystem::path real_;   // dir_ with links resolved: what is exchanged
    std::filesystem::path stage_;
    std::string who_;
    int lock_ = -1;  // an flock on the staging folder: a live run's is never taken for stale
    bool committed_ = false;
};

// The staging folders of `dir` that no live run holds (a killed run's); removes them and
// returns how many. OutputSet calls it; exposed for tests.
int removeStaleOutputStages(const std::filesystem::path& dir);

} // namespace penumbra::app
