// The SPIR-V cache (gpu/ShaderCache.h): a hit for an unchanged shader, a miss for every
// input that changes the SPIR-V, damaged files never trusted, concurrent writers safe.
// Every cache here lives in the test's scratch folder; each ShaderCache object stands for
// one process (its own memory, the folder shared).
#include "ScratchFolder.h"

#include "penumbra/core/Digest.h"
#include "penumbra/core/Error.h"
#include "penumbra/gpu/ShaderCache.h"
#include "penumbra/gpu/ShaderCompiler.h"
#include "penumbra/io/CacheFolder.h"

#include <gtest/gtest.h>
#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <optional>
#include <sstream>
#include <thread>

using namespace penumbra;
namespace fs = std::filesystem;

namespace {

constexpr uint32_t kSpirvMagic = 0x07230203u;

// The engine's log, captured while the object lives.
class CapturedLog {
public:
    CapturedLog() : previous_(spdlog::default_logger())
    {
        spdlog::set_default_logger(
            std::make_shared<spdlog::logger>("captured", std::make_shared<spdlog::sinks::ostream_sink_mt>(text_)));
    }
    ~CapturedLog() { spdlog::set_default_logger(previous_); }
    std::string text() const { return text_.str(); }

private:
    std::ostringstream text_;
    std::shared_ptr<spdlog::logger> previous_;
};

// Sets an environment variable for the test's duration, then puts back what was there.
class ScopedEnv {
public:
    ScopedEnv(const char* name, const char* value) : name_(name)
    {
        if (const char* old = std::getenv(name)) old_ = old;
        value ? ::setenv(name, value, 1) : ::unsetenv(name);
    }
    ~ScopedEnv() { old_ ? ::setenv(name_, old_->c_str(), 1) : ::unsetenv(name_); }

private:
    const char* name_;
    std::optional<std::string> old_;
};

void write(const fs::path& file, const std::string& text) { std::ofstream(file, std::ios::binary) << text; }

class ShaderCacheTest : public test::ScratchFolderTest {
protected:
    void SetUp() override
    {
        test::ScratchFolderTest::SetUp();
        cacheDir = dir / "cache";
        fs::create_directories(dir / "src");
        fs::create_directories(dir / "lib");
        write(dir / "src" / "main.comp", "#version 460\n#include \"helper.glsl\"\n#include <lib.glsl>\n"
                                         "layout(local_size_x = 1) in;\nlayout(set = 0, binding = 0) buffer B { float v[]; };\n"
                                         "void main() { v[0] = helper() + lib() + float(SCALE); }\n");
        write(dir / "src" / "helper.glsl", "float helper() { return 1.0; }\n");
        write(dir / "lib" / "lib.glsl", "float lib() { return 2.0; }\n");
    }

    // A compiler as a technique has one: its folder first, then a shared one.
    gpu::ShaderCompiler compilerFor(gpu::ShaderCache& cache) const { return gpu::ShaderCompiler({dir / "src", dir / "lib"}, cache); }

    std::vector<uint32_t> compileMain(gpu::ShaderCache& cache, const std::string& scale = "3") const
    {
        return compilerFor(cache).compile("main.comp", {{"SCALE", scale}});
    }

    // What glslang makes of the shader as the files are now, without any cache.
    std::vector<uint32_t> uncached(const std::string& scale = "3") const
    {
        gpu::ShaderCache none{fs::path()};
        return compileMain(none, scale);
    }

    // The one entry file the cache folder holds.
    fs::path entryFile() const
    {
        std::vector<fs::path> files;
        for (const auto& e : fs::directory_iterator(cacheDir)) files.push_back(e.path());
        EXPECT_EQ(files.size(), 1u);
        return files.empty() ? fs::path() : files[0];
    }

    fs::path cacheDir;
};

std::vector<unsigned char> readBytes(const fs::path& file)
{
    const std::string text = test::readFile(file);
    return {text.begin(), text.end()};
}

// The entries (<key>.spv), not a writer's temporary file (<key>.spv.tmpXXXXXXXX).
void removeEntries(const fs::path& folder)
{
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(folder, ec))
        if (e.path().extension() == ".spv") fs::remove(e.path(), ec);
}

void writeBytes(const fs::path& file, const std::vector<unsigned char>& bytes)
{
    std::ofstream(file, std::ios::binary | std::ios::trunc).write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

} // namespace

TEST_F(ShaderCacheTest, SecondCompileIsAHitInMemoryThenOnDisk)
{
    gpu::ShaderCache first(cacheDir);
    const std::vector<uint32_t> spirv = compileMain(first);
    ASSERT_GT(spirv.size(), 5u);
    EXPECT_EQ(spirv[0], kSpirvMagic);
    EXPECT_EQ(compileMain(first), spirv);
    EXPECT_EQ(first.stats().compiled, 1u);
    EXPECT_EQ(first.stats().memoryHits, 1u);

    gpu::ShaderCache nextRun(cacheDir);
    EXPECT_EQ(compileMain(nextRun), spirv);
    EXPECT_EQ(nextRun.stats().compiled, 0u);
    EXPECT_EQ(nextRun.stats().diskHits, 1u);
    EXPECT_EQ(nextRun.stats().damagedFiles, 0u);
}

// Each input the SPIR-V depends on is changed in turn: the next compile must run glslang
// and give what an uncached compile gives, the next process must find that entry, and
// with the input changed back the SPIR-V is the first one again.
TEST_F(ShaderCacheTest, EveryInputOfTheShaderIsInTheKey)
{
    struct Change {
        const char* what;
        std::function<void()> apply, undo;
        std::string scale = "3";
    };
    const auto replaceFile = [this](const fs::path& file, const std::string& text) {
        return std::pair<std::function<void()>, std::function<void()>>{
            [file, text] { write(file, text); }, [file, old = test::readFile(file)] { write(file, old); }};
    };
    const auto [editHelper, restoreHelper] = replaceFile(dir / "src" / "helper.glsl", "float helper() { return 5.0; }\n");
    const auto [editLib, restoreLib] = replaceFile(dir / "lib" / "lib.glsl", "float lib() { return 7.0; }\n");
    const auto [editMain, restoreMain] =
        replaceFile(dir / "src" / "main.comp", test::readFile(dir / "src" / "main.comp") + "// a comment\n");
    const std::vector<Change> changes = {
        {"an #include \"x\"'s content", editHelper, restoreHelper},
        {"an #include <x>'s content", editLib, restoreLib},
        {"the shader's own source", editMain, restoreMain},
        // A file of the same name appears earlier on the search path: <lib.glsl> is another file.
        {"which file an #include finds", [this] { write(dir / "src" / "lib.glsl", "float lib() { return 9.0; }\n"); },
         [this] { fs::remove(dir / "src" / "lib.glsl"); }},
        {"a define's value", [] {}, [] {}, "4"},
    };
    {
        gpu::ShaderCache warm(cacheDir);
        compileMain(warm);
    }
    for (const Change& change : changes) {
        SCOPED_TRACE(change.what);
        change.apply();
        const std::vector<uint32_t> expected = uncached(change.scale);
        gpu::ShaderCache process(cacheDir), nextProcess(cacheDir);
        EXPECT_EQ(compileMain(process, change.scale), expected);
        EXPECT_EQ(process.stats().compiled, 1u);
        EXPECT_EQ(compileMain(nextProcess, change.scale), expected);  // the entry just written
        EXPECT_EQ(nextProcess.stats().diskHits, 1u);
        change.undo();
        EXPECT_EQ(compileMain(process), uncached());
    }
}

TEST_F(ShaderCacheTest, StageNameAndDefinesAreInTheKey)
{
    gpu::ShaderCache cache(cacheDir);
    const gpu::ShaderCompiler compiler({dir / "src"}, cache);
    const std::string source = "#version 460\nvoid main() {}\n";
    const auto variants = std::vector<std::function<std::vector<uint32_t>(const gpu::ShaderCompiler&)>>{
        [&](const auto& c) { return c.compileSource(source, "a.vert", VK_SHADER_STAGE_VERTEX_BIT); },
        [&](const auto& c) { return c.compileSource(source, "a.vert", VK_SHADER_STAGE_FRAGMENT_BIT); },
        [&](const auto& c) { return c.compileSource(source, "a.vert", VK_SHADER_STAGE_COMPUTE_BIT); },
        [&](const auto& c) { return c.compileSource(source, "b.vert", VK_SHADER_STAGE_VERTEX_BIT); },
        [&](const auto& c) { return c.compileSource(source, "a.vert", VK_SHADER_STAGE_VERTEX_BIT, {{"X", "1"}}); },
        [&](const auto& c) { return c.compileSource(source, "a.vert", VK_SHADER_STAGE_VERTEX_BIT, {{"X", "2"}}); },
        [&](const auto& c) { return c.compileSource(source, "a.vert", VK_SHADER_STAGE_VERTEX_BIT, {{"X1", ""}}); },
    };
    gpu::ShaderCache none{fs::path()};
    const gpu::ShaderCompiler uncachedCompiler({dir / "src"}, none);
    for (size_t v = 0; v < variants.size(); ++v) {
        SCOPED_TRACE(v);
        EXPECT_EQ(variants[v](compiler), variants[v](uncachedCompiler));
        EXPECT_EQ(cache.stats().compiled, v + 1) << "every variant is an entry of its own";
    }
    for (const auto& variant : variants) variant(compiler);
    EXPECT_EQ(cache.stats().compiled, variants.size());
    EXPECT_EQ(cache.stats().memoryHits, variants.size());
}

// A file in the cache's place that is not a whole entry of its key is reported once,
// never trusted, and replaced.
TEST_F(ShaderCacheTest, DamagedFilesAreIgnoredWithAWarningAndReplaced)
{
    std::vector<unsigned char> good;
    std::vector<uint32_t> spirv;
    fs::path file;
    {
        gpu::ShaderCache writer(cacheDir);
        spirv = compileMain(writer);
        file = entryFile();
        good = readBytes(file);
    }
    ASSERT_GT(good.size(), 64u);
    constexpr size_t kChecksumAt = 40, kPayloadAt = 48;
    // Another shader's entry, copied into this key's name.
    std::vector<unsigned char> otherKey;
    {
        const fs::path other = dir / "other";
        gpu::ShaderCache otherCache(other);
        gpu::ShaderCompiler({dir / "src", dir / "lib"}, otherCache).compile("main.comp", {{"SCALE", "8"}});
        for (const auto& e : fs::directory_iterator(other)) otherKey = readBytes(e.path());
    }
    const auto withChecksum = [&](std::vector<unsigned char> bytes) {
        const uint64_t sum = core::checksum64(bytes.data() + kPayloadAt, bytes.size() - kPayloadAt);
        std::memcpy(bytes.data() + kChecksumAt, &sum, sizeof sum);
        return bytes;
    };
    struct Damage {
        const char* what;
        std::vector<unsigned char> bytes;
        const char* reason;
    };
    std::vector<Damage> damages;
    damages.push_back({"empty", {}, "shorter than the"});
    damages.push_back({"truncated header", {good.begin(), good.begin() + 20}, "shorter than the"});
    damages.push_back({"truncated payload", {good.begin(), good.end() - 7}, "payload bytes, the header says"});
    auto flipped = good;
    flipped[flipped.size() - 5] ^= 0x10;
    damages.push_back({"a flipped byte in the SPIR-V", flipped, "checksum mismatch"});
    auto wrongMagic = good;
    wrongMagic[0] = 'X';
    damages.push_back({"wrong magic", wrongMagic, "wrong magic"});
    auto wrongVersion = good;
    wrongVersion[8] ^= 0x7f;
    damages.push_back({"another format version", wrongVersion, "format version"});
    damages.push_back({"another key's entry", otherKey, "another key"});
    // Well formed, checksum right, but what it holds is not SPIR-V.
    auto notSpirv = good;
    const size_t spirvAt = good.size() - spirv.size() * sizeof(uint32_t);
    notSpirv[spirvAt] ^= 0xff;
    damages.push_back({"a payload that is not SPIR-V", withChecksum(notSpirv), "not its magic number"});
    auto hugeInclude = good;  // an include count far beyond what the payload holds
    const uint32_t count = 0x7fffffff;
    std::memcpy(hugeInclude.data() + kPayloadAt, &count, sizeof count);
    damages.push_back({"a count beyond the payload", withChecksum(hugeInclude), "truncated in"});

    for (const Damage& damage : damages) {
        SCOPED_TRACE(damage.what);
        writeBytes(file, damage.bytes);
        CapturedLog log;
        gpu::ShaderCache reader(cacheDir);
        EXPECT_EQ(compileMain(reader), spirv);
        EXPECT_EQ(reader.stats().damagedFiles, 1u);
        EXPECT_EQ(reader.stats().compiled, 1u);
        EXPECT_EQ(reader.stats().diskHits, 0u);
        const std::string text = log.text();
        EXPECT_NE(text.find(file.string()), std::string::npos) << text;
        EXPECT_NE(text.find(damage.reason), std::string::npos) << text;
        EXPECT_NE(text.find("ignored"), std::string::npos) << text;
        EXPECT_EQ(readBytes(file), good) << "replaced by the fresh compile";
    }
}

TEST_F(ShaderCacheTest, ACacheFileThatIsNotARegularFileIsIgnored)
{
    fs::path file;
    {
        gpu::ShaderCache writer(cacheDir);
        compileMain(writer);
        file = entryFile();
    }
    fs::remove(file);
    fs::create_directory(file);
    CapturedLog log;
    gpu::ShaderCache reader(cacheDir);
    EXPECT_EQ(compileMain(reader), uncached());
    EXPECT_EQ(reader.stats().damagedFiles, 1u);
    EXPECT_NE(log.text().find(file.string()), std::string::npos) << log.text();
}

// Processes writing the same entry at once (parallel tests share one cache folder): every
// reader finds a whole entry or none, never a damaged one.
TEST_F(ShaderCacheTest, ConcurrentWritersLeaveAWholeEntry)
{
    const std::vector<uint32_t> expected = uncached();
    constexpr int kWriters = 4, kRounds = 8;
    std::vector<gpu::ShaderCacheStats> stats(kWriters * kRounds);
    std::vector<int> wrong(kWriters, 0);
    std::vector<std::thread> writers;
    for (int w = 0; w < kWriters; ++w) {
        writers.emplace_back([&, w] {
            for (int round = 0; round < kRounds; ++round) {
                gpu::ShaderCache process(cacheDir);
                if (compileMain(process) != expected) ++wrong[w];
                // Every other round the entry goes, so that writers keep racing readers.
                if (round % 2 == 0) removeEntries(cacheDir);
                stats[size_t(w * kRounds + round)] = process.stats();
            }
        });
    }
    for (std::thread& t : writers) t.join();
    uint64_t compiled = 0, damaged = 0;
    for (const gpu::ShaderCacheStats& s : stats) {
        compiled += s.compiled;
        damaged += s.damagedFiles;
    }
    EXPECT_EQ(damaged, 0u);
    EXPECT_GE(compiled, 1u);
    for (int w = 0; w < kWriters; ++w) EXPECT_EQ(wrong[w], 0) << "writer " << w;
    gpu::ShaderCache after(cacheDir);
    EXPECT_EQ(compileMain(after), expected);
    EXPECT_EQ(after.stats().diskHits, 1u);
    EXPECT_EQ(test::entryNames(cacheDir).size(), 1u) << "no temporary file is left";
}

TEST_F(ShaderCacheTest, FailuresAreNotCachedAndKeepTheirDiagnostics)
{
    write(dir / "src" / "helper.glsl", "float helper() { return undefinedThing; }\n");
    gpu::ShaderCache cache(cacheDir);
    std::string first, second;
    try {
        compileMain(cache);
    } catch (const ShaderCompileError& e) {
        first = e.what();
    }
    try {
        compileMain(cache);
    } catch (const ShaderCompileError& e) {
        second = e.what();
    }
    EXPECT_NE(first.find("helper.glsl:1: error:"), std::string::npos) << first;
    EXPECT_EQ(first, second);
    EXPECT_EQ(cache.stats().compiled, 0u);
    EXPECT_FALSE(fs::exists(cacheDir));
}

TEST_F(ShaderCacheTest, DefaultFolderFollowsTheEnvironment)
{
    {
        ScopedEnv xdg("XDG_CACHE_HOME", (dir / "xdg").c_str());
        ScopedEnv setting("PENUMBRA_SHADER_CACHE", nullptr);
        const fs::path folder = gpu::defaultShaderCacheFolder();
        EXPECT_EQ(folder.parent_path(), dir / "xdg" / "penumbra" / "spirv");
        EXPECT_EQ(folder.filename().string().size(), 40u) << folder << ": the engine's build id (SHA-1, 40 digits)";
        EXPECT_EQ(io::userCacheFolder(), dir / "xdg" / "penumbra");
    }
    {
        ScopedEnv xdg("XDG_CACHE_HOME", "relative/cache");  // invalid under the XDG spec: ignored
        ScopedEnv home("HOME", (dir / "home").c_str());
        EXPECT_EQ(io::userCacheFolder(), dir / "home" / ".cache" / "penumbra");
    }
    {
        ScopedEnv xdg("XDG_CACHE_HOME", (dir / "xdg").c_str());
        ScopedEnv off("PENUMBRA_SHADER_CACHE", "off");
        EXPECT_TRUE(gpu::defaultShaderCacheFolder().empty());
    }
    {
        ScopedEnv xdg("XDG_CACHE_HOME", (dir / "xdg").c_str());
        ScopedEnv typo("PENUMBRA_SHADER_CACHE", "of");
        CapturedLog log;
        EXPECT_FALSE(gpu::defaultShaderCacheFolder().empty());
        EXPECT_NE(log.text().find("PENUMBRA_SHADER_CACHE='of': expected on or off"), std::string::npos) << log.text();
    }
}

TEST_F(ShaderCacheTest, AFolderThatCannotBeWrittenIsOneWarning)
{
    write(dir / "blocked", "a file where the cache folder should be");
    gpu::ShaderCache cache(dir / "blocked" / "spirv");
    CapturedLog log;
    EXPECT_EQ(compileMain(cache), uncached());
    EXPECT_EQ(compileMain(cache, "5"), uncached("5"));
    EXPECT_EQ(cache.stats().compiled, 2u);
    const std::string text = log.text();
    EXPECT_NE(text.find("cannot create the folder"), std::string::npos) << text;
    EXPECT_EQ(text.find("cannot create the folder"), text.rfind("cannot create the folder")) << "once: " << text;
}
