// `penumbra generate`: a generated scene written as glTF, and bad input refused leaving no file.
#include "CliTest.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

using namespace penumbra::test;
namespace fs = std::filesystem;

TEST_F(Cli, GenerateWritesGltfAndBin)
{
    const fs::path gltf = dir / "fence.gltf";
    const CliResult r = run(fmt::format("generate fence -o '{}' --set holes_x=4 --set holes_y=3 --scale 2", gltf.string()));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const std::string json = readFile(gltf);
    EXPECT_NE(json.find("\"name\": \"lattice\""), std::string::npos) << json.substr(0, 400);
    // The buffer is named by its content (fence.<16 hex digits>.bin), the only one there.
    const size_t uri = json.find("\"uri\": \"fence.");
    ASSERT_NE(uri, std::string::npos) << json;
    const std::string bin = json.substr(uri + 8, std::string("fence.0123456789abcdef.bin").size());
    EXPECT_TRUE(bin.ends_with(".bin")) << bin;
    EXPECT_GT(fs::file_size(dir / bin), 0u);
    EXPECT_NE(r.err.find("generated fence"), std::string::npos) << r.err;
}

TEST_F(Cli, GenerateWritesGlbWithSeed)
{
    const fs::path a = dir / "a.glb", b = dir / "b.glb", c = dir / "c.glb";
    ASSERT_EQ(run(fmt::format("generate city -o '{}' --seed 3 --set blocks=2", a.string())).exitCode, 0);
    ASSERT_EQ(run(fmt::format("generate city -o '{}' --seed 3 --set blocks=2", b.string())).exitCode, 0);
    ASSERT_EQ(run(fmt::format("generate city -o '{}' --seed 4 --set blocks=2", c.string())).exitCode, 0);
    EXPECT_EQ(readFile(a).substr(0, 4), "glTF");
    EXPECT_EQ(readFile(a), readFile(b));
    EXPECT_NE(readFile(a), readFile(c));
}

TEST_F(Cli, GenerateRefusesBadInputAndLeavesNoFile)
{
    const std::string out = (dir / "out.glb").string();
    const std::vector<std::pair<std::string, std::string>> cases = {
        {fmt::format("generate castle -o '{}'", out), "unknown generator 'castle'; known: box-grid, penumbra, city, hair, fence"},
        {fmt::format("generate city -o '{}' --set blokcs=4", out), "city: unknown parameter 'blokcs'; did you mean 'blocks'? (known: blocks,"},
        {fmt::format("generate city -o '{}' --set blocks", out), "--set 'blocks': expected name=value"},
        {fmt::format("generate city -o '{}' --set blocks=0", out), "city: blocks must be a whole number in [1, 128], got 0"},
        {fmt::format("generate hair -o '{}' --set alpha=x", out), "hair: alpha must be a number in [0, 1], got 'x'"},
        {fmt::format("generate city -o '{}' --scale -2", out), "--scale must be a finite number > 0, got -2"},
        {fmt::format("generate city -o '{}/out.obj'", dir.string()), "unknown glTF extension '.obj'"},
        {fmt::format("generate city -o '{}/no/such/dir/out.glb'", dir.string()), "does not exist"},
        {"generate city -o /proc/penumbra-out.glb", "/proc/penumbra-out.glb"},
    };
    for (const auto& [args, message] : cases) {
        const CliResult r = run(args);
        EXPECT_EQ(r.exitCode, 1) << args;
        EXPECT_NE(r.err.find(message), std::string::npos) << args << "\n" << r.err;
    }
    EXPECT_FALSE(fs::exists("/proc/penumbra-out.glb"));
    size_t files = 0;
    for (const auto& e : fs::directory_iterator(dir)) files += e.path().extension() != ".txt";
    EXPECT_EQ(files, 0u);
}

TEST_F(Cli, GenerateKeepsTheExistingOutputOnFailure)
{
    const fs::path glb = dir / "scene.glb";
    std::ofstream(glb) << "keep me";
    EXPECT_EQ(run(fmt::format("generate city -o '{}' --set blocks=0", glb.string())).exitCode, 1);
    EXPECT_EQ(readFile(glb), "keep me");
}

// `generate --help` lists every generator's parameter table, each parameter with its
// default, range and doc; the config schema holds the same tables (engine/scene/
// test_generators.cpp holds the schema to the engine's tables), so each line is checked
// against the schema's entry: default, unit, range and doc.
TEST_F(Cli, GenerateHelpListsEveryParameterOfTheTable)
{
    const CliResult help = run("generate --help");
    ASSERT_EQ(help.exitCode, 0) << help.err;
    std::ifstream in(sourceDir() / "config/schema/penumbra-config.schema.json");
    const nlohmann::json schema = nlohmann::json::parse(in);
    const auto number = [](const nlohmann::json& v) { return fmt::format("{}", v.get<double>()); };
    for (const auto& [generator, table] : schema["$defs"]["generatorParams"].items()) {
        if (!table.is_object()) continue;  // the $comment
        const size_t section = help.out.find(fmt::format("\n  {}:\n", generator));
        ASSERT_NE(section, std::string::npos) << generator << "\n" << help.out;
        const size_t end = help.out.find(":\n", section + generator.size() + 5);
        const std::string lines = help.out.substr(section, end == std::string::npos ? std::string::npos : end - section);
        for (const auto& [name, property] : table["properties"].items()) {
            SCOPED_TRACE(fmt::format("{} {}", generator, name));
            const size_t at = lines.find(fmt::format("\n    {} ", name));
            ASSERT_NE(at, std::string::npos) << lines;
            const std::string line = lines.substr(at + 1, lines.find('\n', at + 1) - at - 1);
            // "    block_size      60 world  a number in [10, 1000]  edge of a square block, kerb to kerb"
            EXPECT_TRUE(has(line, fmt::format("  {} ", number(property["default"])))) << line;
            const bool inclusive = property.contains("minimum");
            const std::string lo = number(inclusive ? property["minimum"] : property["exclusiveMinimum"]);
            const std::string range = property.contains("maximum")
                                          ? fmt::format("{}{}, {}]", inclusive ? "[" : "(", lo, number(property["maximum"]))
                                          : fmt::format("{} {}", inclusive ? ">=" : ">", lo);
            EXPECT_TRUE(has(line, fmt::format("{}  ", range))) << range << "\n" << line;
            // The description is the doc, then the unit (shown beside the default).
            std::string doc = property["description"];
            if (const size_t unit = doc.rfind(" (unit: "); unit != std::string::npos) {
                EXPECT_TRUE(has(line, fmt::format(" {} ", doc.substr(unit + 8, doc.size() - unit - 9)))) << line;
                doc.resize(unit);
            }
            EXPECT_TRUE(line.ends_with(fmt::format("  {}", doc))) << line;
        }
    }
}
