#pragma once
// Output files that are never seen half-written: the content goes to a temporary file
// beside the target (same folder, hence the same file system, so the final rename is
// atomic), which replaces the target only once complete. A failed or abandoned write
// leaves the target as it was and removes the temporary file.
#include <filesystem>
#include <fstream>
#include <string_view>

namespace penumbra::io {

// Throws Error naming the path when the folder is missing or not writable, or the
// path is a folder. Called before expensive work so that a bad path fails fast.
void checkWritable(const std::filesystem::path& path);

class StagedFile {
public:
    // Checks that `target` can be written (checkWritable) and picks the temporary name.
    explicit StagedFile(std::filesystem::path target);
    // Removes the temporary file unless commit() moved it into place.
    ~StagedFile();
    StagedFile(const StagedFile&) = delete;
    StagedFile& operator=(const StagedFile&) = delete;

    const std::filesystem::path& target() const { return target_; }
    // Where to write the content.
    const std::filesystem::path& tempPath() const { return temp_; }

    // Opens the temporary file for binary writing. Throws Error naming the target when
    // it cannot be created.
    std::ofstream openTemp() const;

    // Renames the temporary file over the target. Throws Error naming the target.
    void commit();

private:
    std::filesystem::path target_;
    std::filesystem::path temp_;
    bool committed_ = false;
};

// Writes `text` to `path` through a StagedFile: the file appears complete or not at all.
// Throws Error naming the path.
void writeTextFile(const std::filesystem::path& path, std::string_view text);

} // namespace penumbra::io
