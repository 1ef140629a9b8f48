#include "PluginReloader.h"

#include "penumbra/core/Error.h"

#include <fmt/format.h>
#include <unistd.h>

#include <system_error>

namespace fs = std::filesystem;

namespace penumbra::viewer {
bool PluginReloader::isPluginFile(const fs::path& file)
{
    const std::string name = file.filename().string();
    return name.size() > 12 && name.rfind("penumbra-", 0) == 0 && file.extension() == ".so";
}

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

bool PluginReloader::changed()
{
    FileStamps current = scan();
    if (current == stamps_) return false;
    lastChanged_ = changedFiles(stamps_, current);
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
