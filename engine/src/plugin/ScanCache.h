#pragma once
// What the plugin scanner read, kept between runs in one JSON file per engine ABI
// ($XDG_CACHE_HOME/penumbra/plugin-scan-<ABI>.json), keyed by the plugin file's identity:
// its absolute path, device, inode, size and modification time in nanoseconds. A file
// that changed in any of these is scanned again. A cache that cannot be read is ignored
// with a warning; it is written whole to a temporary file that is then renamed over it,
// so a reader never sees half of it and concurrent writers cannot mix their entries.
#include "penumbra/plugin/PluginMetadata.h"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

namespace penumbra::plugin {

// Who a plugin file is, as far as the cache can tell without reading it.
struct FileIdentity {
    std::string path;  // absolute, links resolved
    uint64_t device = 0, inode = 0, size = 0;
    int64_t mtimeNs = 0;
    bool operator==(const FileIdentity&) const = default;
};
// None when the file cannot be examined (the scan then reports why).
std::optional<FileIdentity> identityOf(const std::filesystem::path& file);

class ScanCache {
public:
    // Reads `file` when it exists; an empty path keeps nothing (no cache folder is known).
    explicit ScanCache(std::filesystem::path file);

    std::optional<PluginMetadata> find(const FileIdentity& identity, const std::filesystem::path& file) const;
    // Remembers a successful scan; written by save().
    void store(const FileIdentity& identity, const PluginMetadata& metadata);
    // Writes the cache when store() added anything. A cache that cannot be written is a
    // warning: the next run scans again.
    void save();

    const std::filesystem::path& file() const { return file_; }

private:
    std::filesystem::path file_;
    nlohmann::json entries_ = nlohmann::json::array();
    bool changed_ = false;
};

} // namespace penumbra::plugin
