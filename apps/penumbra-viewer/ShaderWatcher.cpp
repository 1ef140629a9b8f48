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

std::map<std::string, ShaderWatcher::Stamp> ShaderWatcher::scan() const
{
    std::map<std::string, Stamp> stamps;
    for (const fs::path& folder : folders_) {
        std::error_code ec;
        // A file removed while the folder is read is skipped, not an error: the next scan sees it gone.
        for (fs::recursive_directory_iterator it(folder, fs::directory_options::skip_permission_denied, ec), end;
             !ec && it != end; it.increment(ec)) {
            std::error_code fileError;
            if (!it->is_regular_file(fileError) || !isShaderFile(it->path())) continue;
            const auto time = fs::last_write_time(it->path(), fileError);
            const auto size = fs::file_size(it->path(), fileError);
            if (!fileError) stamps[it->path().string()] = {time, size};
        }
    }
    return stamps;
}

bool ShaderWatcher::changed(std::chrono::milliseconds interval)
{
    const auto now = std::chrono::steady_clock::now();
    if (folders_.empty() || now - lastScan_ < interval) return false;
    lastScan_ = now;
    std::map<std::string, Stamp> current = scan();
    if (current == stamps_) return false;
    lastChanged_.clear();
    for (const auto& [file, stamp] : current) {
        const auto old = stamps_.find(file);
        if (old == stamps_.end() || old->second != stamp) lastChanged_.push_back(file);
    }
    for (const auto& [file, stamp] : stamps_) {
        if (!current.count(file)) lastChanged_.push_back(file);
    }
    stamps_ = std::move(current);
    return true;
}

} // namespace penumbra::viewer
