#pragma once
// Hot reload: notices that a shader file under the watched folders was edited, added or
// removed (modification times and sizes, polled), so that the viewer builds the frame's
// pipelines again from disk (FrameRenderer compiles its shaders at construction).
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace penumbra::viewer {

// Modification time and size of each file, by path: what the watchers compare.
using FileStamp = std::pair<std::filesystem::file_time_type, std::uintmax_t>;
using FileStamps = std::map<std::string, FileStamp>;

// The regular files in `folders` (and below them when `recursive`) that `accept` takes. A
// missing folder, or a file removed while it is read, is skipped: the next scan sees it.
FileStamps stampFiles(const std::vector<std::filesystem::path>& folders, bool recursive,
                      const std::function<bool(const std::filesystem::path&)>& accept);
// The files added, changed or removed from `before` to `after`.
std::vector<std::string> changedFiles(const FileStamps& before, const FileStamps& after);

// Whether `file` is GLSL the engine compiles or includes (.glsl .comp .vert .frag .geom .tesc .tese).
bool isShaderFile(const std::filesystem::path& file);

class ShaderWatcher {
public:
    // Folders to watch (recursively), e.g. the engine's shaders/ and each plugin's folder.
    // Missing folders are skipped; the current state is the baseline.
    void watch(std::vector<std::filesystem::path> folders);
    // True once per change since the last call that returned true (or since watch()).
    // Looks at the disk at most every `interval`.
    bool changed(std::chrono::milliseconds interval = std::chrono::milliseconds(250));
    const std::vector<std::filesystem::path>& folders() const { return folders_; }
    // The files that changed in the last change seen, for the message.
    const std::vector<std::string>& lastChanged() const { return lastChanged_; }

private:
    FileStamps scan() const { return stampFiles(folders_, true, isShaderFile); }

    std::vector<std::filesystem::path> folders_;
    FileStamps stamps_;
    std::chrono::steady_clock::time_point lastScan_{};
    std::vector<std::string> lastChanged_;
};


} // namespace penumbra::viewer
