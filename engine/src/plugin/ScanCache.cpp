#include "plugin/ScanCache.h"

#include "penumbra/io/ReadFile.h"
#include "penumbra/plugin/PluginRegistry.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <fstream>

using nlohmann::json;
namespace fs = std::filesystem;

namespace penumbra::plugin {
namespace {

constexpr int kFormat = 1;
// A cache lists a few dozen plugins; beyond this it is not ours.
constexpr uint64_t kMaxCacheBytes = uint64_t(16) << 20;

json identityJson(const FileIdentity& id)
{
    return {{"path", id.path}, {"device", id.device}, {"inode", id.inode}, {"size", id.size}, {"mtime_ns", id.mtimeNs}};
}

} // namespace

std::optional<FileIdentity> identityOf(const fs::path& file)
{
    std::error_code ec;
    const fs::path canonical = fs::canonical(file, ec);
    struct stat status{};
    if (ec || ::stat(canonical.c_str(), &status) != 0 || !S_ISREG(status.st_mode)) return std::nullopt;
    return FileIdentity{canonical.string(), uint64_t(status.st_dev), uint64_t(status.st_ino), uint64_t(status.st_size),
                        int64_t(status.st_mtim.tv_sec) * 1000000000 + status.st_mtim.tv_nsec};
}

ScanCache::ScanCache(fs::path file) : file_(std::move(file))
{
    std::error_code ec;
    if (file_.empty() || !fs::exists(fs::symlink_status(file_, ec))) return;
    try {
        const json doc = json::parse(io::readRegularTextFile(file_, kMaxCacheBytes, "a plugin scan cache (JSON)"));
        if (!doc.is_object() || doc.value("format", 0) != kFormat || doc.value("abi", 0u) != PENUMBRA_PLUGIN_ABI_VERSION ||
            !doc.contains("entries") || !doc["entries"].is_array()) {
            throw std::runtime_error("not a plugin scan cache of this engine");
        }
        entries_ = doc["entries"];
    } catch (const std::exception& e) {
        spdlog::warn("{}: ignoring the plugin scan cache ({}); plugins are scanned again and the cache is rewritten",
                     file_.string(), e.what());
        changed_ = true;  // replaced by a good one at the next save
    }
}

std::optional<PluginMetadata> ScanCache::find(const FileIdentity& identity, const fs::path& file) const
{
    const json key = identityJson(identity);
    for (const json& entry : entries_) {
        if (!entry.is_object() || entry.value("file", json()) != key || !entry.contains("plugin")) continue;
        try {
            return PluginMetadata::fromJson(entry["plugin"], file);
        } catch (const PluginError&) {
            return std::nullopt;  // a damaged entry: scanned again and replaced
        }
    }
    return std::nullopt;
}

void ScanCache::store(const FileIdentity& identity, const PluginMetadata& metadata)
{
    if (file_.empty()) return;
    json kept = json::array();
    for (json& entry : entries_) {
        // One entry a path: the file's older versions are gone.
        if (entry.is_object() && entry.contains("file") && entry["file"].is_object() && entry["file"].value("path", "") == identity.path) continue;
        kept.push_back(std::move(entry));
    }
    kept.push_back({{"file", identityJson(identity)}, {"plugin", metadata.toJson()}});
    entries_ = std::move(kept);
    changed_ = true;
}

void ScanCache::save()
{
    if (file_.empty() || !changed_) return;
    changed_ = false;
    // Unique to this writer: other processes and other registries in this one write too.
    static std::atomic<uint64_t> writes{0};
    const fs::path temp = file_.parent_path() / fmt::format(".{}.{}.{}.tmp", file_.filename().string(), ::getpid(), writes++);
    std::error_code ec;
    fs::create_directories(file_.parent_path(), ec);
    std::string why = "cannot write the temporary file";
    {
        std::ofstream out(temp, std::ios::binary | std::ios::trunc);
        out << json{{"format", kFormat}, {"abi", PENUMBRA_PLUGIN_ABI_VERSION}, {"entries", entries_}}.dump(1, ' ', false, json::error_handler_t::replace) << '\n';
        out.close();
        if (out) {
            fs::rename(temp, file_, ec);
            if (!ec) return;
            why = ec.message();
        }
    }
    fs::remove(temp, ec);
    spdlog::warn("{}: cannot write the plugin scan cache ({}); plugins will be scanned again next time", file_.string(), why);
}

} // namespace penumbra::plugin
