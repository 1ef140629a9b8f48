// What every command shares: usage errors, hostile configs and long values named where they
// were given, the README's synopsis of every flag, and a sweep ignored where it does not apply.
#include "CliTest.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>

using namespace penumbra::test;
namespace fs = std::filesystem;

// Hostile configs (issue 20) exit 1 with the place named, for every command that reads
// a config: never 2 (an internal error), never a crash.
TEST_F(Cli, HostileConfigsExitOneNamingThePlace)
{
    const std::string longName(5000, 'n');
    const struct {
        const char* file;
        std::string text;
        std::string expected;
    } cases[] = {
        {"big.json", R"({"camera": {"position": [0, 1e309, 10]}})", "big.json: /camera/position/1: number overflow"},
        {"deep.json", "{\"x\":" + std::string(40000, '[') + std::string(40000, ']') + "}", "nested deeper than 64 levels"},
        {"inc.json", "{\"include\": \"" + longName + ".json\"}", "inc.json: /include: cannot resolve"},
        {"sweep.json",
         R"({"camera": {"position": [0, 5, 10], "target": [0, 0, 0]}, "lights": [{"position": [0, 10, 0], "target": [0, 0, 0]}],
             "sweep": [{"path": "/lights/99999999999999999999999/intensity", "values": [1, 2]}]})",
         "sweep.json: /sweep/0/path: "},
    };
    for (const auto& c : cases) {
        const fs::path cfg = dir / c.file;
        std::ofstream(cfg) << c.text;
        for (const char* command : {"validate", "render"}) {
            if (std::string(c.file) == "sweep.json" && std::string(command) == "render") continue;  // render ignores sweeps
            SCOPED_TRACE(std::string(command) + " " + c.file);
            const std::string output = std::string(command) == "render" ? fmt::format(" -o '{}/out.png'", dir.string()) : "";
            const CliResult r = run(fmt::format("{} '{}'{}", command, cfg.string(), output));
            EXPECT_EQ(r.exitCode, 1) << r.err.substr(0, 400);
            EXPECT_NE(r.err.find(c.expected), std::string::npos) << r.err.substr(0, 400);
            EXPECT_FALSE(fs::exists(dir / "out.png"));
        }
    }
}

TEST_F(Cli, UsageErrors)
{
    EXPECT_NE(run("").exitCode, 0);
    EXPECT_NE(run("render").exitCode, 0);
    EXPECT_NE(run(fmt::format("render {} -o x.png --frames 0", config("default.json"))).exitCode, 0);
}

// The README's synopsis (the block under "## The `penumbra` command") names every flag
// that each subcommand's --help offers, and the program's own (-v).
TEST_F(Cli, TheReadmeSynopsisNamesEveryFlag)
{
    const std::string readme = readFile(penumbra::test::sourceDir() / "README.md");
    const size_t section = readme.find("## The `penumbra` command");
    ASSERT_NE(section, std::string::npos);
    const size_t open = readme.find("```\n", section), close = readme.find("```", open + 4);
    ASSERT_NE(close, std::string::npos);
    const std::string synopsis = readme.substr(open + 4, close - open - 4);
    // Each subcommand's lines: from "penumbra NAME" to the next line that starts with "penumbra ".
    const auto linesOf = [&](const std::string& name) {
        size_t at = synopsis.find("penumbra " + name);
        while (at != std::string::npos && std::string(" \n").find(synopsis[at + 9 + name.size()]) == std::string::npos)
            at = synopsis.find("penumbra " + name, at + 1);
        if (at == std::string::npos) return std::string();
        const size_t next = synopsis.find("\npenumbra ", at);
        return synopsis.substr(at, next == std::string::npos ? std::string::npos : next - at);
    };
    const auto flagsOf = [](const std::string& help) {
        std::set<std::string> flags;
        std::istringstream lines(help);
        for (std::string line; std::getline(lines, line);) {
            std::istringstream words(line);
            std::string first;
            words >> first;
            if (first.rfind("-", 0) == 0 && first != "-h,--help") flags.insert(first);
        }
        return flags;
    };
    // "-o,--output": either spelling will do.
    const auto names = [](const std::string& text, const std::string& flag) {
        std::istringstream spellings(flag);
        for (std::string spelling; std::getline(spellings, spelling, ',');)
            if (has(text, spelling + " ") || has(text, spelling + "|") || has(text, spelling + "]")) return true;
        return false;
    };
    for (const std::string name : {"render", "graph", "compare", "bench", "plugins", "generate", "validate", "devices"}) {
        SCOPED_TRACE(name);
        const CliResult help = run(name + " --help");
        ASSERT_EQ(help.exitCode, 0) << help.err;
        const std::string lines = linesOf(name);
        ASSERT_FALSE(lines.empty()) << "no synopsis for " << name;
        for (const std::string& flag : flagsOf(help.out)) EXPECT_TRUE(names(lines, flag)) << flag << " not in\n" << lines;
    }
    const CliResult help = run("--help");
    for (const std::string& flag : flagsOf(help.out)) EXPECT_TRUE(names(synopsis, flag)) << flag;
}

// Issue 43: a value of 100 KB (an argument holds at most 128 KiB) or a 1 MB string in a
// config is shown shortened, and the message still names where it was given.
TEST_F(Cli, LongValuesAreShownShortenedNamingThePlace)
{
    const std::string longArg(100000, 'y');
    const fs::path cfg = dir / "long.json";
    std::ofstream(cfg) << R"({"camera": {"position": [0, 5, 10], "target": [0, 0, 0]},
        "lights": [{"type": "spot", "position": [0, 10, 0], "target": [0, 0, 0],
                    "shadow": {"technique": "hard", "pcf_kernel": ")"
                       << std::string(1 << 20, 'k') << R"("}}]})";
    const struct {
        std::string args;
        std::string where;
    } cases[] = {
        {fmt::format("validate '{}'", cfg.string()), "long.json: /lights/0/shadow/pcf_kernel: must be an odd integer"},
        {fmt::format("validate {} --set hard.pcf_kernel={}", config("default.json"), longArg),
         "--set hard.pcf_kernel: must be an odd integer"},
        {fmt::format("render {} -o '{}/out.png' --culling {}", config("default.json"), dir.string(), longArg), "--culling"},
        {fmt::format("render {} -o '{}/out.png' --debug-range {}", config("default.json"), dir.string(), longArg),
         "--debug-range 'yyy"},
        {fmt::format("generate box-grid -o '{}/g.gltf' --set rows={}", dir.string(), longArg), "rows must be a whole number"},
    };
    for (const auto& c : cases) {
        SCOPED_TRACE(c.where);
        const CliResult r = run(c.args);
        EXPECT_NE(r.exitCode, 0);
        EXPECT_LT(r.err.size(), 4000u) << r.err.substr(0, 400);
        EXPECT_TRUE(has(r.err, c.where)) << r.err.substr(0, 400);
    }
    EXPECT_FALSE(fs::exists(dir / "out.png"));
}

TEST_F(Cli, RenderCompareAndGraphSayThatTheyIgnoreASweep)
{
    const fs::path cfg = dir / "swept.json";
    std::ofstream(cfg) << R"({"camera": {"position": [0, 5, 10], "target": [0, 0, 0]},
        "lights": [{"type": "spot", "position": [0, 10, 0], "target": [0, 0, 0]}],
        "sweep": [{"path": "/lights/0/intensity", "values": [1, 2]}]})";
    for (const char* command : {"render", "compare", "graph"}) {
        SCOPED_TRACE(command);
        const std::string output = std::string(command) == "render" ? fmt::format(" -o '{}/out.png'", dir.string()) : "";
        // The warning comes while the config is read, before the device (here: none) is chosen.
        const CliResult r = run(fmt::format("{} '{}'{} --device no-such-gpu", command, cfg.string(), output));
        EXPECT_TRUE(has(r.err, fmt::format("swept.json: /sweep: {} ignores the sweep and draws the config as written; "
                                           "`penumbra bench` runs its variants",
                                           command)))
            << r.err;
    }
}
