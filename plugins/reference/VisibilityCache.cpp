#include "VisibilityCache.h"

#include "penumbra/core/Digest.h"
#include "penumbra/core/Error.h"
#include "penumbra/io/CacheFolder.h"
#include "penumbra/io/ReadFile.h"
#include "penumbra/io/StagedFile.h"

#include <fmt/format.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>

namespace penumbra::reference {
namespace {

constexpr char kMagic[8] = {'P', 'N', 'B', 'R', 'V', 'I', 'S', '1'};
constexpr size_t kHeaderBytes = sizeof kMagic + 2 * sizeof(uint64_t) + 2 * sizeof(uint32_t);

template <class T> void append(std::vector<char>& bytes, const T& value)
{
    const auto* p = reinterpret_cast<const char*>(&value);
    bytes.insert(bytes.end(), p, p + sizeof value);
}

template <class T> T readAt(const std::vector<unsigned char>& bytes, size_t offset)
{
    T value;
    std::memcpy(&value, bytes.data() + offset, sizeof value);
    return value;
}

} // namespace

std::filesystem::path defaultCacheFolder()
{
    if (const char* dir = std::getenv("PENUMBRA_CACHE_DIR"); dir && *dir) return dir;
    return io::userCacheFolder();
}

std::string keyText(const CacheKey& key) { return fmt::format("{:016x}{:016x}", key[1], key[0]); }

std::filesystem::path VisibilityCache::fileFor(const CacheKey& key) const { return folder_ / (keyText(key) + ".vis"); }

VisibilityCache::Lookup VisibilityCache::load(const CacheKey& key, uint32_t width, uint32_t height) const
{
    Lookup result;
    const std::filesystem::path path = fileFor(key);
    const size_t pixels = size_t(width) * height;
    const size_t expected = kHeaderBytes + pixels * sizeof(float) + sizeof(uint64_t);
    std::vector<unsigned char> bytes;
    try {
        // A FIFO in the cache folder would block the read: read as every input file is.
        bytes = io::readRegularFile(path, expected, "a visibility cache file");
    } catch (const io::FileReadError& e) {
        if (e.problem() == io::FileReadProblem::NotFound) return result;  // not cached
        result.rejected = e.what();
        return result;
    }
    if (bytes.size() != expected) {
        result.rejected = fmt::format("{}: only {} bytes, expected {} for {} x {}", path.string(), bytes.size(), expected,
                                      width, height);
        return result;
    }
    const size_t checked = expected - sizeof(uint64_t);
    if (std::memcmp(bytes.data(), kMagic, sizeof kMagic) != 0) {
        result.rejected = fmt::format("{}: not a visibility cache file of this version", path.string());
    } else if (readAt<uint64_t>(bytes, 8) != key[0] || readAt<uint64_t>(bytes, 16) != key[1]) {
        result.rejected = fmt::format("{}: holds another key", path.string());
    } else if (readAt<uint32_t>(bytes, 24) != width || readAt<uint32_t>(bytes, 28) != height) {
        result.rejected = fmt::format("{}: holds a {} x {} image, expected {} x {}", path.string(),
                                      readAt<uint32_t>(bytes, 24), readAt<uint32_t>(bytes, 28), width, height);
    } else if (core::checksum64(bytes.data(), checked) != readAt<uint64_t>(bytes, checked)) {
        result.rejected = fmt::format("{}: checksum mismatch (a damaged file)", path.string());
    }
    if (!result.rejected.empty()) return result;
    std::vector<float> values(pixels);
    std::memcpy(values.data(), bytes.data() + kHeaderBytes, pixels * sizeof(float));
    for (size_t i = 0; i < pixels; ++i)
        if (!(values[i] >= 0.0f && values[i] <= 1.0f)) {
            result.rejected = fmt::format("{}: pixel {} holds {}, outside [0, 1]", path.string(), i, values[i]);
            return result;
        }
    result.values = std::move(values);
    return result;
}

void VisibilityCache::store(const CacheKey& key, uint32_t width, uint32_t height, std::span<const float> values) const
{
    if (values.size() != size_t(width) * height)
        throw Error(fmt::format("reference cache: {} values for a {} x {} image", values.size(), width, height));
    std::error_code error;
    std::filesystem::create_directories(folder_, error);
    if (error)
        throw Error(fmt::format("reference cache: cannot create the folder {}: {}", folder_.string(), error.message()));
    std::vector<char> bytes(kMagic, kMagic + sizeof kMagic);
    append(bytes, key[0]);
    append(bytes, key[1]);
    append(bytes, width);
    append(bytes, height);
    const auto* payload = reinterpret_cast<const char*>(values.data());
    bytes.insert(bytes.end(), payload, payload + values.size_bytes());
    append(bytes, core::checksum64(bytes.data(), bytes.size()));

    io::StagedFile file(fileFor(key));
    std::ofstream out = file.openTemp();
    out.write(bytes.data(), std::streamsize(bytes.size()));
    out.close();
    if (!out) throw Error(fmt::format("reference cache: could not write {}", file.target().string()));
    file.commit();
}

} // namespace penumbra::reference
