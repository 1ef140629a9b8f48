#include "penumbra/gpu/ShaderCache.h"

#include "penumbra/core/Error.h"
#include "penumbra/core/ShortText.h"
#include "penumbra/io/CacheFolder.h"
#include "penumbra/io/ReadFile.h"
#include "penumbra/io/StagedFile.h"

#include "core/LibraryBuildId.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string_view>
#include <utility>

namespace fs = std::filesystem;

namespace penumbra::gpu {
namespace {

constexpr char kMagic[8] = {'P', 'N', 'B', 'R', 'S', 'P', 'V', '\0'};
constexpr size_t kHeaderBytes = sizeof kMagic + 2 * sizeof(uint32_t) + sizeof(ShaderKey) + 2 * sizeof(uint64_t);
constexpr uint32_t kSpirvMagic = 0x07230203u;
constexpr size_t kSpirvHeaderWords = 5;  // magic, version, generator, bound, schema
// The largest shipped shader's SPIR-V is ~16 KB; anything near this limit is not ours.
constexpr uint64_t kMaxFileBytes = uint64_t(64) << 20;
// Builds of the engine whose folders are kept besides the running one's (spirv/<build id>).
constexpr size_t kOtherBuildsKept = 4;

class Writer {
public:
    template <class T> void value(const T& v)
    {
        const auto* p = reinterpret_cast<const unsigned char*>(&v);
        bytes.insert(bytes.end(), p, p + sizeof v);
    }
    void text(const std::string& s)
    {
        value(uint32_t(s.size()));
        bytes.insert(bytes.end(), s.begin(), s.end());
    }
    std::vector<unsigned char> bytes;
};

// Why a file is not a whole entry of the key it was read for.
struct Damaged {
    std::string why;
};

// Reads a file's fields in order; a field past the end is a truncated file.
class Reader {
public:
    Reader(const std::vector<unsigned char>& bytes, size_t offset) : bytes_(bytes), at_(offset) {}

    template <class T> T value(const char* what)
    {
        T v;
        std::memcpy(&v, take(sizeof v, what), sizeof v);
        return v;
    }
    std::string text(const char* what)
    {
        const auto size = value<uint32_t>(what);
        const auto* p = take(size, what);
        return std::string(reinterpret_cast<const char*>(p), size);
    }
    size_t left() const { return bytes_.size() - at_; }

private:
    const unsigned char* take(size_t size, const char* what)
    {
        if (size > left()) throw Damaged{fmt::format("truncated in {}", what)};
        const unsigned char* p = bytes_.data() + at_;
        at_ += size;
        return p;
    }
    const std::vector<unsigned char>& bytes_;
    size_t at_;
};

std::vector<unsigned char> encode(const ShaderKey& key, const std::vector<ShaderInclude>& includes,
                                  const std::vector<uint32_t>& spirv)
{
    Writer payload;
    payload.value(uint32_t(includes.size()));
    for (const ShaderInclude& include : includes) {
        payload.value(uint8_t(include.local ? 1 : 0));
        payload.text(include.header);
        payload.text(include.includer);
        payload.text(include.resolved);
        payload.value(include.contentHash);
    }
    payload.value(uint32_t(spirv.size()));
    for (uint32_t word : spirv) payload.value(word);

    Writer file;
    for (char c : kMagic) file.value(c);
    file.value(ShaderCache::kFormatVersion);
    file.value(uint32_t(0));
    file.value(key);
    file.value(uint64_t(payload.bytes.size()));
    file.value(core::checksum64(payload.bytes.data(), payload.bytes.size()));
    file.bytes.insert(file.bytes.end(), payload.bytes.begin(), payload.bytes.end());
    return std::move(file.bytes);
}

// The includes and SPIR-V of a file of `key`; throws Damaged saying what is wrong.
std::pair<std::vector<ShaderInclude>, std::vector<uint32_t>> decode(const std::vector<unsigned char>& bytes,
                                                                    const ShaderKey& key)
{
    if (bytes.size() < kHeaderBytes)
        throw Damaged{fmt::format("{} bytes, shorter than the {}-byte header", bytes.size(), kHeaderBytes)};
    if (std::memcmp(bytes.data(), kMagic, sizeof kMagic) != 0) throw Damaged{"not a SPIR-V cache file (wrong magic)"};
    Reader header(bytes, sizeof kMagic);
    if (const auto version = header.value<uint32_t>("the format version"); version != ShaderCache::kFormatVersion)
        throw Damaged{fmt::format("format version {}, expected {}", version, ShaderCache::kFormatVersion)};
    header.value<uint32_t>("the header");
    if (header.value<ShaderKey>("the key") != key) throw Damaged{"holds the entry of another key"};
    const auto payloadBytes = header.value<uint64_t>("the payload size");
    const auto checksum = header.value<uint64_t>("the checksum");
    if (payloadBytes != bytes.size() - kHeaderBytes)
        throw Damaged{fmt::format("{} payload bytes, the header says {}", bytes.size() - kHeaderBytes, payloadBytes)};
    if (core::checksum64(bytes.data() + kHeaderBytes, payloadBytes) != checksum) throw Damaged{"checksum mismatch"};

    Reader payload(bytes, kHeaderBytes);
    // One by one: a damaged count runs into the payload's end, not into a huge allocation.
    std::vector<ShaderInclude> includes;
    for (auto count = payload.value<uint32_t>("the include count"); count > 0; --count) {
        ShaderInclude& include = includes.emplace_back();
        include.local = payload.value<uint8_t>("an include") != 0;
        include.header = payload.text("an include's header");
        include.includer = payload.text("an include's includer");
        include.resolved = payload.text("an include's file");
        include.contentHash = payload.value<ShaderKey>("an include's hash");
    }
    const auto words = payload.value<uint32_t>("the SPIR-V size");
    if (words < kSpirvHeaderWords || size_t(words) * sizeof(uint32_t) != payload.left())
        throw Damaged{fmt::format("a SPIR-V of {} words in {} bytes", words, payload.left())};
    std::vector<uint32_t> spirv(words);
    for (uint32_t& word : spirv) word = payload.value<uint32_t>("the SPIR-V");
    if (spirv[0] != kSpirvMagic) throw Damaged{fmt::format("SPIR-V starts with {:#010x}, not its magic number", spirv[0])};
    return {std::move(includes), std::move(spirv)};
}

bool isBuildIdName(const std::string& name)
{
    return !name.empty() && std::all_of(name.begin(), name.end(), [](char c) { return std::isxdigit(static_cast<unsigned char>(c)); });
}

// Each rebuilt engine gets a folder of its own: keep the most recently written few of the
// others (another installed engine, the last builds) so that the cache cannot grow forever.
void pruneOtherBuilds(const fs::path& ownFolder)
{
    std::error_code ec;
    std::vector<std::pair<fs::file_time_type, fs::path>> others;
    for (const fs::directory_entry& entry : fs::directory_iterator(ownFolder.parent_path(), ec)) {
        if (entry.path() == ownFolder || !entry.is_directory(ec) || entry.is_symlink(ec)) continue;
        if (!isBuildIdName(entry.path().filename().string())) continue;
        others.emplace_back(entry.last_write_time(ec), entry.path());
    }
    if (others.size() <= kOtherBuildsKept) return;
    std::sort(others.begin(), others.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
    for (size_t i = kOtherBuildsKept; i < others.size(); ++i) {
        fs::remove_all(others[i].second, ec);
        if (ec) spdlog::debug("shader cache: could not remove {}: {}", others[i].second.string(), ec.message());
    }
}

// The shared cache's folder; a build that has none yet is new: older builds' folders go.
fs::path sharedFolder()
{
    fs::path folder = defaultShaderCacheFolder();
    std::error_code ec;
    if (!folder.empty() && !fs::exists(folder, ec)) pruneOtherBuilds(folder);
    return folder;
}

} // namespace

ShaderCache::ShaderCache(fs::path folder) : folder_(std::move(folder)) {}

ShaderCache& ShaderCache::shared()
{
    static ShaderCache cache(sharedFolder());
    return cache;
}

fs::path ShaderCache::fileFor(const ShaderKey& key) const
{
    return folder_ / fmt::format("{:016x}{:016x}.spv", key[1], key[0]);
}

ShaderCacheStats ShaderCache::stats() const
{
    std::lock_guard lock(mutex_);
    return stats_;
}

std::optional<std::vector<uint32_t>> ShaderCache::find(const ShaderKey& key, const IncludeCheck& isCurrent)
{
    std::optional<Entry> held;
    {
        std::lock_guard lock(mutex_);
        if (auto it = memory_.find(key); it != memory_.end()) held = it->second;
    }
    if (held) {
        // An #included file edited while the process runs: compiled again, then replaced.
        if (!isCurrent(held->includes)) return std::nullopt;
        std::lock_guard lock(mutex_);
        ++stats_.memoryHits;
        return std::move(held->spirv);
    }
    if (folder_.empty()) return std::nullopt;
    std::optional<Entry> read = readFile(key);
    if (!read || !isCurrent(read->includes)) return std::nullopt;
    std::lock_guard lock(mutex_);
    ++stats_.diskHits;
    memory_.insert_or_assign(key, *read);
    return std::move(read->spirv);
}

void ShaderCache::store(const ShaderKey& key, std::vector<ShaderInclude> includes, std::vector<uint32_t> spirv)
{
    Entry entry{std::move(includes), std::move(spirv)};
    if (!folder_.empty()) writeFile(key, entry);
    std::lock_guard lock(mutex_);
    ++stats_.compiled;
    memory_.insert_or_assign(key, std::move(entry));
}

std::optional<ShaderCache::Entry> ShaderCache::readFile(const ShaderKey& key)
{
    const fs::path path = fileFor(key);
    std::string why;
    try {
        // Read as every input file is: a FIFO put in the cache's place must not block.
        auto [includes, spirv] = decode(io::readRegularFile(path, kMaxFileBytes, "a SPIR-V cache file"), key);
        return Entry{std::move(includes), std::move(spirv)};
    } catch (const io::FileReadError& e) {
        // Not compiled before; or no folder to hold entries (writing says why, once).
        std::error_code ec;
        if (e.problem() == io::FileReadProblem::NotFound || !fs::is_directory(folder_, ec)) return std::nullopt;
        why = e.reason();
    } catch (const Damaged& d) {
        why = d.why;
    }
    spdlog::warn("shader cache: {}: {}; ignored, the shader is compiled again and the file replaced", path.string(), why);
    std::lock_guard lock(mutex_);
    ++stats_.damagedFiles;
    return std::nullopt;
}

void ShaderCache::writeFile(const ShaderKey& key, const Entry& entry)
{
    const std::vector<unsigned char> bytes = encode(key, entry.includes, entry.spirv);
    try {
        std::error_code ec;
        fs::create_directories(folder_, ec);
        if (ec) throw Error(fmt::format("cannot create the folder {}: {}", folder_.string(), ec.message()));
        io::StagedFile file(fileFor(key));
        std::ofstream out = file.openTemp();
        out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
        out.close();
        if (!out) throw Error(fmt::format("{}: could not be written", file.target().string()));
        file.commit();
    } catch (const Error& e) {
        std::lock_guard lock(mutex_);
        if (std::exchange(writeWarned_, true)) return;
        spdlog::warn("shader cache: {}; shaders are compiled again next run (PENUMBRA_SHADER_CACHE=off keeps them in "
                     "memory only)",
                     e.what());
    }
}

fs::path defaultShaderCacheFolder()
{
    if (const char* setting = std::getenv("PENUMBRA_SHADER_CACHE"); setting && *setting) {
        const std::string_view value = setting;
        if (value == "off") return {};
        if (value != "on")
            spdlog::warn("PENUMBRA_SHADER_CACHE='{}': expected on or off; the disk cache stays on",
                         core::shortText(std::string(value)));
    }
    const fs::path root = io::userCacheFolder();
    const std::string& build = core::engineBuildId();
    if (root.empty() || build.empty()) return {};
    return root / "spirv" / build;
}

} // namespace penumbra::gpu
