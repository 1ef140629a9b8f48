#include "ShaderWatcher.h"

#include <algorithm>
#include <system_error>

namespace fs = std::filesystem;

namespace penumbra::viewer {

bool isShaderFile(const fs::path& file)
{
    static const char* kExtensions[] = {".glsl", ".comp", ".vert", ".frag", ".geom", ".tesc", ".tese"};
    const std::string ext = file.extension().string();
    return std::any_of(std::begin(kExtensions), std::end(kExtensions), [&](const char* e) { return ext == e; });
}

void ShaderWatcher::watch(std::vector<fs::path> folders)
{
    std::sort(folders.begin(), folders.end());
    folders.erase(std::unique(folders.begin(), folders.end()), folders.end());
    folders_ = std::move(folders);
    stamps_ = scan();
    lastScan_ = std::chrono::steady_clock::now();
    lastChanged_.clear();
}

FileStamps stampFiles(const std::vector<fs::path>& folders, bool recursive, const std::function<bool(const fs::path&)>& accept)
{
    FileStamps stamps;
    auto stamp = [&](const fs::directory_entry& entry) {
        std::error_code fileError;
        if (!entry.is_regular_file(fileError) || !accept(entry.path())) return;
        const auto time = fs::last_write_time(entry.path(), fileError);
        const auto size = fs::file_size(entry.path(), fileError);
        if (!fileError) stamps[entry.path().string()] = {time, size};
    };
    for (const fs::path& folder : folders) {
        std::error_code ec;
        if (recursive) {
            for (fs::recursive_directory_iterator it(folder, fs::directory_options::skip_permission_denied, ec), end;
                 !ec && it != end; it.increment(ec)) {
                stamp(*it);
            }
        } else {
            for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) stamp(*it);
        }
    }
    return stamps;
}

std::vector<std::string> changedFiles(const FileStamps& before, const FileStamps& after)
{
    std::vector<std::string> changed;
    for (const auto& [file, stamp] : after) {
        const auto old = before.find(file);
        if (old == before.end() || old->second != stamp) changed.push_back(file);
    }
    for (const auto& [file, stamp] : before) {
        if (!after.count(file)) changed.push_back(file);
    }
    return changed;
}

bool ShaderWatcher::changed(std::chrono::milliseconds interval)
{
    const auto now = std::chrono::steady_clock::now();
    if (folders_.empty() || now - lastScan_ < interval) return false;
    lastScan_ = now;
    FileStamps current = scan();
    if (current == stamps_) return false;
    lastChanged_ = changedFiles(stamps_, current);
    stamps_ = std::move(current);
    return true;
}

} // namespace penumbra::viewer
