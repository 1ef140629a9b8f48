#include "PluginReloader.h"

#include "penumbra/core/Error.h"

#include <fmt/format.h>
#include <unistd.h>

#include <system_error>

namespace fs = std::filesystem;

namespace penumbra::viewer {
namespace {

bool isPluginFile(const fs::path& file)
{
    const std::string name = file.filename().string();
    return name.size() > 12 && name.rfind("penumbra-", 0) == 0 && file.extension() == ".so";
}

} // namespace

PluginReloader::PluginReloader(std::vector<fs::path> searchPath) : searchPath_(std::move(searchPath))
{
    stamps_ = scan();
    root_ = fs::temp_directory_path() / fmt::format("penumbra-viewer-plugins-{}", ::getpid());
}

PluginReloader::~PluginReloader()
{
    std::error_code ec;
    fs::remove_all(root_, ec);
}

std::map<std::string, PluginReloader::Stamp> PluginReloader::scan() const
{
    std::map<std::string, Stamp> stamps;
    for (const fs::path& folder : searchPath_) {
        std::error_code ec;
        for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
            std::error_code fileError;
            if (!isPluginFile(it->path()) || !it->is_regular_file(fileError)) continue;
            const auto time = fs::last_write_time(it->path(), fileError);
            const auto size = fs::file_size(it->path(), fileError);
            if (!fileError) stamps[it->path().string()] = {time, size};
        }
    }
    return stamps;
}

bool PluginReloader::changed()
{
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

std::unique_ptr<plugin::PluginRegistry> PluginReloader::freshRegistry()
{
    const fs::path folder = root_ / std::to_string(++generation_);
    std::error_code ec;
    fs::create_directories(folder, ec);
    if (ec) throw Error(fmt::format("{}: cannot make the folder for reloaded plugins: {}", folder.string(), ec.message()));
    for (const fs::path& dir : searchPath_) {
        for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
            std::error_code fileError;
            if (!isPluginFile(it->path()) || !it->is_regular_file(fileError)) continue;
            const fs::path copy = folder / it->path().filename();
            if (fs::exists(copy, fileError)) continue;  // the first on the search path wins, as for the registry
            fs::copy_file(it->path(), copy, fileError);
            if (fileError) {
                throw Error(fmt::format("{}: cannot copy the plugin for reloading: {}", it->path().string(), fileError.message()));
            }
            // An installed plugin's shaders lie beside it (<folder>/<name>/): the copy sees them there too.
            const std::string name = it->path().stem().string().substr(9);
            const fs::path shaders = dir / name;
            if (fs::is_directory(shaders, fileError) && !fs::exists(folder / name, fileError)) {
                fs::create_directory_symlink(fs::absolute(shaders), folder / name, fileError);
            }
        }
    }
    std::vector<fs::path> path = {folder};
    path.insert(path.end(), searchPath_.begin(), searchPath_.end());
    return std::make_unique<plugin::PluginRegistry>(path);
}

} // namespace penumbra::viewer
