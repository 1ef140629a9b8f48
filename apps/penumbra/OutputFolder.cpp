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

void checkOutputFolder(const fs::path& dir, const std::vector<fs::path>& files, const std::string& who)
{
    std::error_code ec;
    if (!fs::exists(dir, ec)) {
        const fs::path parent = dir.has_parent_path() ? dir.parent_path() : fs::path(".");
        if (!fs::exists(parent, ec)) {
            throw Error(fmt::format("{}: cannot create the folder: '{}' does not exist", who, parent.string()));
        }
        if (!fs::is_directory(parent, ec)) {
            throw Error(fmt::format("{}: cannot create the folder: '{}' is not a folder", who, parent.string()));
        }
        // Only creating it tells for sure (permissions that root ignores, read-only or
        // special file systems); removed again, so that a run that fails or is
        // interrupted leaves nothing behind.
        if (!fs::create_directory(dir, ec)) {
            throw Error(fmt::format("{}: cannot create the folder: {}", who, ec.message()));
        }
        fs::remove(dir, ec);
        return;
    }
    if (!fs::is_directory(dir, ec)) throw Error(fmt::format("{}: exists and is not a folder", who));
    for (const fs::path& file : files) io::checkWritable(file);
}

void createOutputFolder(const fs::path& dir, const std::string& who)
{
    std::error_code ec;
    if (!fs::is_directory(dir, ec) && !fs::create_directory(dir, ec) && ec) {
        throw Error(fmt::format("{}: cannot create the folder: {}", who, ec.message()));
    }
}

} // namespace penumbra::app
