#pragma once
// Reference visibility images on disk, keyed by a 128-bit hash of everything they depend
// on (README.md, "Cache"). One file per key, `<key>.vis` in the cache folder:
//
//   "PNBRVIS1"            8 bytes, the format
//   key                   16 bytes (low, high), checked against the name's
//   width, height         2 x uint32
//   V                     width x height float32, row-major, top row first
//   checksum              uint64, XXH3-64 of everything before it (core::checksum64)
//
// Files are written to a temporary name and renamed into place (io::StagedFile), so a
// reader never sees half a file; a file whose size, format, key, size or checksum is
// wrong, or that holds a V outside [0, 1], is rejected with the reason and recomputed.
#include "penumbra/core/Digest.h"

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace penumbra::reference {

using CacheKey = core::Hash128;

// $PENUMBRA_CACHE_DIR, else the user cache folder (io::userCacheFolder: $XDG_CACHE_HOME/penumbra,
// else $HOME/.cache/penumbra); empty when none of them is set (no cache then).
std::filesystem::path defaultCacheFolder();

// A 32-digit hexadecimal rendering of a key, for file names and messages.
std::string keyText(const CacheKey& key);

class VisibilityCache {
public:
    explicit VisibilityCache(std::filesystem::path folder) : folder_(std::move(folder)) {}

    const std::filesystem::path& folder() const { return folder_; }
    std::filesystem::path fileFor(const CacheKey& key) const;

    struct Lookup {
        std::optional<std::vector<float>> values;  // a hit
        std::string rejected;                      // why a file that exists was not used
    };
    // The image stored under `key`, if a valid one of that size exists.
    Lookup load(const CacheKey& key, uint32_t width, uint32_t height) const;

    // Stores the image; throws penumbra::Error naming the file when it cannot.
    void store(const CacheKey& key, uint32_t width, uint32_t height, std::span<const float> values) const;

private:
    std::filesystem::path folder_;
};

} // namespace penumbra::reference
