// Config files as an attacker or a broken generator writes them (issue 20): every one is
// a ConfigError (the CLI's exit 1) naming the file and the JSON path, never an internal
// error, a crash or a hang. Numbers beyond a double's range, nesting beyond
// config::kMaxConfigNesting (checked while parsing, before anything recurses), file names
// the file system refuses, sweep paths with array indices beyond 64 bits or a million
// levels; FIFOs, devices and files beyond config::kMaxConfigBytes; long names and paths
// are shortened in messages.
#include "ScratchFolder.h"

#include "penumbra/config/Config.h"
#include "penumbra/config/Document.h"
#include "penumbra/config/Sweep.h"
#include "penumbra/core/Error.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <string>

using namespace penumbra;
namespace fs = std::filesystem;

namespace {

// A folder of its own per test, removed after it.
class HostileConfig : public ::testing::Test {
protected:
    void SetUp() override { dir_ = test::makeScratchFolder("hostile"); }
    void TearDown() override { fs::remove_all(dir_); }

    fs::path write(const std::string& name, const std::string& text) const
    {
        const fs::path file = dir_ / name;
        std::ofstream(file, std::ios::binary) << text;
        return file;
    }

    // The ConfigError of loading and expanding `file` (every variant of its sweep).
    static std::string errorLoading(const fs::path& file)
    {
        try {
            config::expandSweep(config::loadDocument(file));
        } catch (const ConfigError& e) {
            return e.what();
        }
        ADD_FAILURE() << file << " was accepted";
        return {};
    }

    static std::string minimalWith(const std::string& lightsIntensity)
    {
        return R"({"camera": {"position": [0, 5, 10], "target": [0, 0, 0]},
                   "lights": [{"type": "spot", "position": [0, 10, 0], "target": [0, 0, 0], "intensity": )" +
               lightsIntensity + "}]}";
    }

    fs::path dir_;
};

} // namespace

TEST_F(HostileConfig, NumbersBeyondADoubleNameTheirPath)
{
    for (const char* number : {"1e309", "-1e999", "1e400000", "123456789e400"}) {
        SCOPED_TRACE(number);
        const std::string what = errorLoading(write("big.json", minimalWith(number)));
        EXPECT_NE(what.find("big.json: /lights/0/intensity: "), std::string::npos) << what;
        EXPECT_NE(what.find(number), std::string::npos) << what;
        EXPECT_NE(what.find("double's range"), std::string::npos) << what;
    }
    // In an array, at the top level, in an included file.
    EXPECT_NE(errorLoading(write("array.json", R"({"camera": {"position": [0, 1e309, 10]}})")).find("/camera/position/1: "),
              std::string::npos);
    EXPECT_NE(errorLoading(write("top.json", R"({"frames": 1e309})")).find("top.json: /frames: "), std::string::npos);
    write("base.json", R"({"output": {"width": 2e999}})");
    const std::string included = errorLoading(write("inc.json", R"({"include": "base.json"})"));
    EXPECT_NE(included.find("base.json: /output/width: "), std::string::npos) << included;
}

TEST_F(HostileConfig, NestingIsLimitedWhileParsing)
{
    // kMaxConfigNesting levels parse (the config is then refused for what it says, not
    // for its depth); one more, of objects or arrays, is refused naming the limit and the
    // path it reached.
    const auto nested = [](int levels, bool arrays) { return "{\"x\":" + test::nestedJson(levels - 1, arrays) + "}"; };
    for (bool arrays : {false, true}) {
        SCOPED_TRACE(arrays ? "arrays" : "objects");
        const std::string ok = errorLoading(write("ok.json", nested(config::kMaxConfigNesting, arrays)));
        EXPECT_EQ(ok.find("nested deeper"), std::string::npos) << ok;
        const std::string deep = errorLoading(write("deep.json", nested(config::kMaxConfigNesting + 1, arrays)));
        EXPECT_NE(deep.find("deep.json: /x/"), std::string::npos) << deep.substr(0, 200);
        EXPECT_NE(deep.find("nested deeper than 64 levels"), std::string::npos) << deep.substr(0, 400);
        // 40,000 levels (the depth that overflowed the stack): the same error.
        const std::string hostile = errorLoading(write("hostile.json", nested(40000, arrays)));
        EXPECT_NE(hostile.find("nested deeper than 64 levels"), std::string::npos) << hostile.substr(0, 400);
    }
}

TEST_F(HostileConfig, FileNamesTheFileSystemRefusesAreNamedShortened)
{
    const std::string longName(5000, 'n');
    // As an include, alone and in a list.
    for (const std::string& include : {"\"" + longName + ".json\"", "[\"" + longName + ".json\"]"}) {
        const std::string what = errorLoading(write("inc.json", "{\"include\": " + include + "}"));
        EXPECT_NE(what.find("inc.json: /include"), std::string::npos) << what;
        EXPECT_NE(what.find("too long"), std::string::npos) << what;
        EXPECT_NE(what.find("characters)"), std::string::npos) << what;
        EXPECT_LT(what.size(), 600u) << "the name is shortened";
    }
    // As the config file itself.
    const std::string what = errorLoading(dir_ / (longName + ".json"));
    EXPECT_NE(what.find("too long"), std::string::npos) << what;
    EXPECT_LT(what.size(), 600u);
}

TEST_F(HostileConfig, OnlyRegularFilesOfBoundedSizeAreRead)
{
    // A FIFO would block the read forever, a device never end it: refused by type, as the
    // config itself and as an include, before any read.
    const fs::path fifo = dir_ / "pipe.json";
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    std::string what = errorLoading(fifo);
    EXPECT_NE(what.find("pipe.json: is a FIFO (named pipe), expected a JSON config file"), std::string::npos) << what;
    what = errorLoading(write("inc.json", R"({"include": "pipe.json"})"));
    EXPECT_NE(what.find("a FIFO"), std::string::npos) << what;
    for (const char* device : {"/dev/zero", "/dev/null"}) {
        what = errorLoading(write("dev.json", fmt::format(R"({{"include": "{}"}})", device)));
        EXPECT_NE(what.find(fmt::format("{}: is a character device, expected a JSON config file", device)), std::string::npos)
            << what;
    }
    what = errorLoading(dir_);
    EXPECT_NE(what.find(fmt::format("{}: is a directory, expected a JSON config file", dir_.filename().string())),
              std::string::npos)
        << what;
    // One byte beyond kMaxConfigBytes (a sparse file: nothing is written) is refused by
    // its size; a file of exactly the limit is read (and refused as JSON, not for size).
    const fs::path big = write("big.json", "");
    fs::resize_file(big, config::kMaxConfigBytes + 1);
    what = errorLoading(big);
    EXPECT_NE(what.find(fmt::format("big.json: is {} bytes; a config file holds at most 64 MiB", config::kMaxConfigBytes + 1)),
              std::string::npos)
        << what;
    fs::resize_file(big, config::kMaxConfigBytes);
    what = errorLoading(big);
    EXPECT_EQ(what.find("at most 64 MiB"), std::string::npos) << what;
    EXPECT_NE(what.find("malformed JSON"), std::string::npos) << what;
}

TEST_F(HostileConfig, SweepPathsBeyondTheConfigAreRefused)
{
    const auto sweep = [&](const std::string& path) {
        return nlohmann::json{{"camera", {{"position", {0, 5, 10}}, {"target", {0, 0, 0}}}},
                              {"lights", {{{"type", "spot"}, {"position", {0, 10, 0}}, {"target", {0, 0, 0}}}}},
                              {"sweep", {{{"path", path}, {"values", {1, 2}}}}}}
            .dump();
    };
    // Array indices beyond 64 bits, and beyond the array.
    for (const char* index : {"99999999999999999999999", "18446744073709551616", "4294967296", "1"}) {
        SCOPED_TRACE(index);
        const std::string what = errorLoading(write("s.json", sweep(std::string("/lights/") + index + "/intensity")));
        EXPECT_NE(what.find("s.json: /sweep/0/path: "), std::string::npos) << what;
    }
    // More levels than a config nests: refused before the pointer is built (a million
    // levels took minutes), the message shortened.
    for (int levels : {config::kMaxConfigNesting + 1, 1000000}) {
        std::string path;
        for (int i = 0; i < levels; ++i) path += "/a";
        const std::string what = errorLoading(write("s.json", sweep(path)));
        EXPECT_NE(what.find("/sweep/0/path: a path of " + std::to_string(levels) + " levels"), std::string::npos)
            << what.substr(0, 300);
        EXPECT_LT(what.size(), 400u);
    }
    // One key of two million characters: named shortened.
    const std::string what = errorLoading(write("s.json", sweep("/" + std::string(2000000, 'k'))));
    EXPECT_NE(what.find("(2000001 characters)"), std::string::npos) << what.substr(0, 300);
    EXPECT_LT(what.size(), 1000u);
}

TEST(ShortText, KeepsShortTextAndShortensLongText)
{
    EXPECT_EQ(config::shortText("/lights/0/shadow"), "/lights/0/shadow");
    EXPECT_EQ(config::shortText(std::string(160, 'x')), std::string(160, 'x'));
    const std::string s = config::shortText(std::string(100, 'a') + std::string(100, 'b'));
    EXPECT_EQ(s, std::string(80, 'a') + "…" + std::string(60, 'b') + " (200 characters)");
}
