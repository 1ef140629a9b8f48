#pragma once
// Output files that are never seen half-written. The content goes to an unnamed file in
// the target's folder (O_TMPFILE: same file system, no name to leave behind), which
// gets a temporary name beside the target only once complete and is renamed over it at
// once (atomic). A failed or abandoned write leaves the target as it was; a process
// killed while writing leaves nothing. Where the file system has no O_TMPFILE the file is
// written under its temporary name (<target>.tmpXXXXXXXX) from the start.
//
// A temporary name that a killed run left (in the moment between naming and rename, or
// while writing on a file system without O_TMPFILE) is removed by the next StagedFile for
// the same target. A writer holds an flock on its file until it is done, so a concurrent
// writer's temporary file is never taken for a stale one.
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <string_view>

namespace penumbra::io {

// Throws Error naming the path when the folder is missing or not writable, or the
// path is a folder. Called before expensive work so that a bad path fails fast.
void checkWritable(const std::filesystem::path& path);

class StagedFile {
public:
    // Checks that `target` can be written (checkWritable), removes the temporary files
    // that killed writers of `target` left, and creates the file to write. Throws Error
    // naming the target when it cannot be created.
    explicit StagedFile(std::filesystem::path target);
    // Discards the content unless commit() moved it into place.
    ~StagedFile();
    StagedFile(const StagedFile&) = delete;
    StagedFile& operator=(const StagedFile&) = delete;

    const std::filesystem::path& target() const { return target_; }
    // A path to write the content to, for libraries that open a file by name (stb, OpenEXR):
    // /proc/self/fd/N for an unnamed file, else the temporary name.
    const std::filesystem::path& tempPath() const { return writePath_; }

    // Opens the file for binary writing (from its start). Throws Error naming the target
    // when it cannot be opened.
    std::ofstream openTemp() const;

    // Moves the content over the target. Throws Error naming the target.
    void commit();

    // Whether this file is unnamed until commit() (O_TMPFILE).
    bool unnamed() const { return unnamed_; }

private:
    std::filesystem::path target_;
    std::filesystem::path writePath_;  // what tempPath() gives
    std::filesystem::path named_;      // the temporary name; until commit() only without O_TMPFILE
    int fd_ = -1;                      // holds the flock that marks the file as being written
    bool unnamed_ = false;
    bool committed_ = false;
};

// The temporary names of `target`'s writers: <file name>.tmp and 8 hex digits.
bool isTemporaryNameOf(const std::filesystem::path& target, const std::filesystem::path& candidate);

// Removes the temporary files of `target` that no live writer holds (a killed run's);
// returns how many. StagedFile calls it; exposed for tests.
int removeStaleTemporaries(const std::filesystem::path& target);

// What a killed writer can leave behind: a temporary file, or a staging folder.
enum class Leftover { File, Folder };
// Removes, in `folder`, each entry of the kind `kind` whose file name `isLeftover` accepts
// and on which no live process holds an flock (its writer was killed: the lock died with
// it; a live writer holds one until it is done). Never follows a link, and removes an
// entry only while its name still names what was found unlocked. Returns how many.
int removeAbandoned(const std::filesystem::path& folder, Leftover kind,
                    const std::function<bool(const std::string& name)>& isLeftover);

// Writes `text` to `path` through a StagedFile: the file appears complete or not at all.
// Throws Error naming the path.
void writeTextFile(const std::filesystem::path& path, std::string_view text);

} // namespace penumbra::io
