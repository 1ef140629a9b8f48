#include "OutputFolder.h"

#include "penumbra/core/Error.h"
#include "penumbra/io/StagedFile.h"

#include <fmt/format.h>

namespace fs = std::filesystem;

namespace penumbra::app {

fs::path outputFolder(const std::string& flag)
{
    fs::path dir = fs::path(flag).lexically_normal();
    if (!dir.empty() && dir.filename().empty()) dir = dir.parent_path();
    return dir;
}

void checkOutputFolder(const fs::path& dir, const std::vector<fs::path>& files)
{
    std::error_code ec;
    if (!fs::exists(dir, ec)) {
        const fs::path parent = dir.has_parent_path() ? dir.parent_path() : fs::path(".");
        if (!fs::is_directory(parent, ec)) {
            throw Error(fmt::format("-o {}: cannot create the folder: '{}' does not exist", dir.string(), parent.string()));
        }
        io::checkWritable(dir);  // the parent is writable
        return;
    }
    if (!fs::is_directory(dir, ec)) throw Error(fmt::format("-o {}: exists and is not a folder", dir.string()));
    for (const fs::path& file : files) io::checkWritable(file);
}

void createOutputFolder(const fs::path& dir)
{
    std::error_code ec;
    if (!fs::is_directory(dir, ec) && !fs::create_directory(dir, ec) && ec) {
        throw Error(fmt::format("-o {}: cannot create the folder: {}", dir.string(), ec.message()));
    }
}

} // namespace penumbra::app
