#pragma once
// The SPIR-V of every shader compiled, shared by all ShaderCompilers of a process and kept
// on disk between runs, so that a second run compiles nothing (README.md, "Layout";
// docs/performance.md, "Start-up: the SPIR-V cache").
//
// An entry is found by a key that ShaderCompiler derives from everything the compile reads
// besides #included files: the engine build (its GNU build id, which covers the glslang
// linked into it), glslang's version, every compile option, the stage, the shader's name,
// source and defines, and the cache format. The #includes glslang asked for are recorded
// with the entry (what was asked, which file it resolved to, a hash of its content); the
// entry is used only while every one of them still resolves to the same file with the
// same content. glslang is deterministic, so the same inputs and the same answers to its
// #include requests make the same SPIR-V: a stale entry cannot be found.
// (Keying by glslang's preprocessed text would need no recorded #includes, but glslang's
// preprocessor builds the same built-in symbol tables as a compile, ~120 ms a process:
// a warm start would save little.)
//
// On disk, one file per key, <folder>/<32 hex digits of the key>.spv:
//
//   "PNBRSPV" NUL            8 bytes, the kind of file
//   format version           uint32 (kFormatVersion), then uint32 0
//   key                      16 bytes (low, high): must be the name's
//   payload size             uint64: the bytes after the header
//   checksum                 uint64, XXH3-64 of the payload
//   payload: include count   uint32, then per include:
//              local         uint8 (1: #include "x", 0: #include <x>)
//              header, includer, resolved file: each uint32 length + bytes
//              content hash  16 bytes
//            SPIR-V          uint32 word count, then the words (the first is 0x07230203)
//
// Files are written to a temporary file that is renamed into place (io::StagedFile), so a
// reader never sees half a file and concurrent writers (parallel tests, two renders) leave
// one whole entry. A file that is truncated, damaged or not an entry of this key is never
// trusted: it is reported with one warning naming it, counted, and replaced by a fresh
// compile.
#include "penumbra/core/Digest.h"

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace penumbra::gpu {

using ShaderKey = core::Hash128;

// One #include glslang asked for while compiling a shader, and what it got.
struct ShaderInclude {
    bool local = false;    // #include "x" (searched beside the includer first), else <x>
    std::string header;    // as written
    std::string includer;  // the including file's name
    std::string resolved;  // the file it resolved to; empty when none could be read
    ShaderKey contentHash{};
    bool operator==(const ShaderInclude&) const = default;
};

struct ShaderCacheStats {
    uint64_t compiled = 0;      // shaders glslang compiled (and the cache then kept)
    uint64_t memoryHits = 0;    // found in this process's memory
    uint64_t diskHits = 0;      // read from a file an earlier run (or process) wrote
    uint64_t damagedFiles = 0;  // cache files ignored as damaged, with a warning
};

class ShaderCache {
public:
    static constexpr uint32_t kFormatVersion = 1;

    // `folder` holds the disk entries; empty keeps entries in memory only.
    explicit ShaderCache(std::filesystem::path folder);
    ShaderCache(const ShaderCache&) = delete;
    ShaderCache& operator=(const ShaderCache&) = delete;

    // The cache every ShaderCompiler uses unless given another, on defaultShaderCacheFolder().
    static ShaderCache& shared();

    const std::filesystem::path& folder() const { return folder_; }
    std::filesystem::path fileFor(const ShaderKey& key) const;
    ShaderCacheStats stats() const;

    // The SPIR-V kept under `key` whose recorded includes `isCurrent` accepts: from memory,
    // else from the disk. None when there is no such entry (the caller compiles). Thread-safe.
    using IncludeCheck = std::function<bool(const std::vector<ShaderInclude>&)>;
    std::optional<std::vector<uint32_t>> find(const ShaderKey& key, const IncludeCheck& isCurrent);

    // Keeps a freshly compiled shader in memory and on disk. A file that cannot be written
    // is a warning (once per cache): the next run compiles again. Thread-safe.
    void store(const ShaderKey& key, std::vector<ShaderInclude> includes, std::vector<uint32_t> spirv);

private:
    struct Entry {
        std::vector<ShaderInclude> includes;
        std::vector<uint32_t> spirv;
    };
    std::optional<Entry> readFile(const ShaderKey& key);
    void writeFile(const ShaderKey& key, const Entry& entry);

    std::filesystem::path folder_;
    mutable std::mutex mutex_;  // guards memory_, stats_ and writeWarned_
    std::map<ShaderKey, Entry> memory_;
    ShaderCacheStats stats_;
    bool writeWarned_ = false;
};

// Where the shared cache keeps its files: <user cache folder>/spirv/<engine build id>
// (io::userCacheFolder, core::engineBuildId). Empty, so memory only, when
// PENUMBRA_SHADER_CACHE is "off", or no user cache folder or build id is known.
std::filesystem::path defaultShaderCacheFolder();

} // namespace penumbra::gpu
