#include "OutputFolder.h"

#include "penumbra/core/Error.h"
#include "penumbra/io/StagedFile.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <fcntl.h>
#include <stdio.h>  // renameat2 (glibc 2.28)
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <set>

namespace fs = std::filesystem;

namespace penumbra::app {
namespace {

constexpr std::string_view kStageInfix = ".penumbra-";
constexpr size_t kStageRandomChars = 6;  // mkdtemp's XXXXXX

// `dir` made absolute with its links resolved (as far as it exists): the folder the
// exchange must swap, not a link to it.
fs::path realFolder(const fs::path& dir)
{
    std::error_code ec;
    fs::path real = fs::weakly_canonical(fs::absolute(dir, ec), ec);
    if (ec) real = fs::absolute(dir).lexically_normal();
    if (real.filename().empty() && real.has_parent_path() && real != real.root_path()) real = real.parent_path();  // "out/"
    return real;
}

// Appended piece by piece: GCC 12 at -O3 warns (-Wrestrict, a false positive) on
// `"." + std::string&&` inlined into some unity batches.
std::string stagePrefix(const fs::path& real)
{
    std::string prefix = ".";
    prefix += real.filename().string();
    prefix += kStageInfix;
    return prefix;
}

std::set<std::string> entryNames(const fs::path& dir)
{
    std::set<std::string> names;
    for (const auto& e : fs::directory_iterator(dir)) names.insert(e.path().filename().string());
    return names;
}

} // namespace

bool sameFolder(const fs::path& a, const fs::path& b) { return realFolder(a) == realFolder(b); }

int removeStaleOutputStages(const fs::path& dir)
{
    const fs::path real = realFolder(dir);
    const std::string prefix = stagePrefix(real);
    // A live run holds an flock on its staging folder; a killed one's died with it.
    return io::removeAbandoned(real.parent_path(), io::Leftover::Folder, [&](const std::string& name) {
        return name.size() == prefix.size() + kStageRandomChars && name.compare(0, prefix.size(), prefix) == 0;
    });
}

OutputSet::OutputSet(fs::path dir, std::string who) : dir_(std::move(dir)), real_(realFolder(dir_)), who_(std::move(who))
{
    removeStaleOutputStages(real_);
    std::string pattern = (real_.parent_path() / (stagePrefix(real_) + std::string(kStageRandomChars, 'X'))).string();
    if (!::mkdtemp(pattern.data())) {
        throw Error(fmt::format("{}: cannot create a staging folder beside it: {}", who_, std::strerror(errno)));
    }
    stage_ = pattern;
    lock_ = ::open(stage_.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (lock_ >= 0) ::flock(lock_, LOCK_EX);
}

OutputSet::~OutputSet()
{
    if (!committed_) {
        std::error_code ec;
        fs::remove_all(stage_, ec);
    }
    if (lock_ >= 0) ::close(lock_);
}

bool OutputSet::commit()
{
    const std::set<std::string> written = entryNames(stage_);
    std::error_code ec;
    if (::mkdir(real_.c_str(), 0777) != 0 && errno != EEXIST) {
        throw Error(fmt::format("{}: cannot create the folder: {}", who_, std::strerror(errno)));
    }
    // Why the exchange cannot keep the user's files, if it cannot.
    std::string why;
    const fs::path cwd = fs::current_path(ec);
    if (!ec && std::mismatch(real_.begin(), real_.end(), cwd.begin(), cwd.end()).first == real_.end()) {
        why = "it is the working folder or holds it";  // a shell there would be left in the old folder
    }
    std::error_code listError;
    for (fs::directory_iterator it(real_, listError), end; why.empty() && !listError && it != end; it.increment(listError)) {
        const fs::directory_entry& entry = *it;
        const std::string name = entry.path().filename().string();
        if (written.count(name)) continue;  // the command's own file: replaced
        if (entry.is_directory(ec) && !entry.is_symlink(ec)) {
            why = fmt::format("it holds the folder '{}', which cannot be hard-linked", name);
        } else if (::linkat(AT_FDCWD, entry.path().c_str(), AT_FDCWD, (stage_ / name).c_str(), 0) != 0) {
            why = fmt::format("'{}' cannot be hard-linked ({})", name, std::strerror(errno));
        }
    }
    if (why.empty() && listError) why = fmt::format("its files cannot be listed ({})", listError.message());
    if (why.empty()) {
        struct stat st {};
        if (::stat(real_.c_str(), &st) == 0) ::chmod(stage_.c_str(), st.st_mode & 07777);
        if (::renameat2(AT_FDCWD, stage_.c_str(), AT_FDCWD, real_.c_str(), RENAME_EXCHANGE) == 0) {
            // stage_ now names the old folder: its set and the second links of the user's files.
            committed_ = true;
            fs::remove_all(stage_, ec);
            return true;
        }
        why = fmt::format("the file system cannot exchange two folders ({})", std::strerror(errno));
    }
    spdlog::warn("{}: {}; its files are replaced one by one instead of all at once", who_, why);
    for (const std::string& name : written) {
        fs::rename(stage_ / name, real_ / name, ec);
        if (ec) throw Error(fmt::format("{}: cannot move '{}' into place: {}", who_, name, ec.message()));
    }
    committed_ = true;
    fs::remove_all(stage_, ec);  // and the links made for the exchange
    return false;
}

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
