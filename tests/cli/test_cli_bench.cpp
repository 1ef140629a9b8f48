// `penumbra bench`: a config's sweep measured against one reference per scene (results.csv,
// results.json, pareto.svg, the summary), refusing bad input before rendering or writing.
#include "CliTest.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <string>
#include <vector>

using namespace penumbra::test;
namespace fs = std::filesystem;

namespace {

// RFC 4180: fields split at commas outside quotes, "" inside quotes is one quote, records
// end with CRLF.
std::vector<std::vector<std::string>> readCsv(const std::string& text)
{
    std::vector<std::vector<std::string>> rows;
    std::vector<std::string> row(1);
    bool quoted = false;
    for (size_t i = 0; i < text.size(); ++i) {
        const char c = text[i];
        if (quoted && c == '"' && i + 1 < text.size() && text[i + 1] == '"') {
            row.back() += '"';
            ++i;
        } else if (c == '"') {
            quoted = !quoted;
        } else if (!quoted && c == ',') {
            row.emplace_back();
        } else if (!quoted && c == '\r' && i + 1 < text.size() && text[i + 1] == '\n') {
            rows.push_back(std::move(row));
            row.assign(1, "");
            ++i;
        } else {
            row.back() += c;
        }
    }
    EXPECT_EQ(row, std::vector<std::string>(1)) << "the last record ends with CRLF";
    return rows;
}

// A CSV as records keyed by the header's column names.
std::vector<std::map<std::string, std::string>> csvRecords(const std::string& text)
{
    const std::vector<std::vector<std::string>> rows = readCsv(text);
    std::vector<std::map<std::string, std::string>> records;
    for (size_t r = 1; r < rows.size(); ++r) {
        EXPECT_EQ(rows[r].size(), rows[0].size()) << "row " << r << " has every column";
        std::map<std::string, std::string> record;
        for (size_t c = 0; c < rows[0].size() && c < rows[r].size(); ++c) record[rows[0][c]] = rows[r][c];
        records.push_back(std::move(record));
    }
    return records;
}

// testGoodConfig at 64 x 48 with the key light's fill swept over 0.25 and 0.5 (the other
// light renders unshadowed): against the reference testgood fill=0.75, every error is known.
std::string benchConfig(const std::string& sweep = R"([{"path": "/lights/0/shadow/fill", "values": [0.25, 0.5]}])")
{
    return testGoodConfig(R"(, "fill": 0.25)", fmt::format(R"(, "output": {{"width": 64, "height": 48}}, "sweep": {})", sweep));
}

} // namespace

TEST_F(Cli, BenchMeasuresEveryVariantAgainstOneReferenceRender)
{
    const fs::path cfg = dir / "cfg.json";
    std::ofstream(cfg) << benchConfig();
    const fs::path out = dir / "out";
    const CliResult r = run(fmt::format("bench '{}' {} --frames 2 --warmup 1 -o '{}' --validation", cfg.string(),
                                        kTestGoodReference, out.string()),
                            pluginPath());
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_EQ(entryNames(out), (std::set<std::string>{"results.csv", "results.json", "pareto.svg"}));
    EXPECT_TRUE(has(r.err, "variant 1/2: /lights/0/shadow/fill=0.25")) << r.err;
    EXPECT_TRUE(has(r.err, "variant 2/2: /lights/0/shadow/fill=0.5")) << r.err;

    // One row per variant x light, every column filled; errors exact: |fill - 0.75| on
    // every geometry pixel, and the unshadowed light's |1 - 0.75|.
    const std::vector<std::map<std::string, std::string>> rows = csvRecords(readFile(out / "results.csv"));
    ASSERT_EQ(rows.size(), 4u);
    const std::vector<std::string> rmse = {"0.5", "0.25", "0.25", "0.25"};
    const std::vector<std::string> technique = {"testgood", "unshadowed", "testgood", "unshadowed"};
    for (size_t i = 0; i < rows.size(); ++i) {
        SCOPED_TRACE(i);
        const std::map<std::string, std::string>& row = rows[i];
        EXPECT_EQ(row.at("variant"), std::to_string(i / 2));
        EXPECT_EQ(row.at("light_index"), std::to_string(i % 2));
        EXPECT_EQ(row.at("light"), i % 2 ? "fill" : "key");
        EXPECT_EQ(row.at("technique"), technique[i]);
        EXPECT_NEAR(std::stod(row.at("rmse")), std::stod(rmse[i]), kVStep);
        EXPECT_NEAR(std::stod(row.at("mae")), std::stod(rmse[i]), kVStep);
        EXPECT_NEAR(std::stod(row.at("max_abs_error")), std::stod(rmse[i]), kVStep);
        EXPECT_EQ(row.at("pct_above_0.05"), "100");
        EXPECT_EQ(row.at("pct_above_0.2"), "100");
        EXPECT_EQ(row.at("pct_above_0.5"), "0");  // |ΔV| <= 0.5 everywhere
        EXPECT_EQ(row.at("penumbra_pixels"), row.at("pixels")) << "V_ref = 0.75 everywhere: all penumbra";
        EXPECT_EQ(row.at("umbra_pixels"), "0");
        EXPECT_EQ(row.at("umbra_rmse"), "0");
        EXPECT_EQ(row.at("memory_bytes"), "0") << "neither the clear nor the unshadowed light has resources of its own";
        EXPECT_EQ(row.at("technique_host_ms"), "0") << "no host pass";
        EXPECT_EQ(row.at("technique_ms"), row.at("technique_gpu_ms")) << "without host passes, the time is the GPU's";
        EXPECT_EQ(row.at("scene"), "box-grid");
        EXPECT_EQ(row.at("width"), "64");
        EXPECT_EQ(row.at("culling"), "none");
        EXPECT_EQ(row.at("triangles_drawn"), "0") << "neither the clear nor the unshadowed light draws casters";
        for (const char* column : {"technique_ms", "technique_gpu_ms", "technique_host_ms", "technique_cpu_ms", "frame_gpu_ms",
                                   "frame_wall_ms", "ssim"}) {
            EXPECT_NO_THROW((void)std::stod(row.at(column))) << column;
        }
    }
    EXPECT_GT(std::stoi(rows[0].at("pixels")), 0);
    // The README's list of the columns names each (a region's column by its name without
    // the region's prefix).
    const std::string readme = readFile(penumbra::test::sourceDir() / "README.md");
    const size_t listStart = readme.find("- `results.csv`:"), listEnd = readme.find("- `results.json`:", listStart);
    ASSERT_NE(listEnd, std::string::npos);
    const std::string list = readme.substr(listStart, listEnd - listStart);
    for (const auto& [column, value] : rows[0]) {
        std::string name = column;
        for (const char* region : {"umbra_", "penumbra_", "lit_"})
            if (name.rfind(region, 0) == 0 && rows[0].count(name.substr(std::strlen(region)))) name = name.substr(std::strlen(region));
        EXPECT_TRUE(has(list, "`" + name + "`")) << column << " is not in the README's list of results.csv's columns";
    }
    EXPECT_EQ(rows[2].at("label"), "/lights/0/shadow/fill=0.5");
    EXPECT_EQ(nlohmann::json::parse(rows[2].at("params"))["fill"], 0.5);
    EXPECT_EQ(rows[3].at("params"), "null");
    // The sweep sets the key light's technique and, for the fill light, its context.
    EXPECT_EQ(rows[2].at("technique_label"), "fill=0.5");
    EXPECT_EQ(rows[2].at("context"), "");
    EXPECT_EQ(rows[3].at("technique_label"), "");
    EXPECT_EQ(rows[3].at("context"), "fill=0.5");
    EXPECT_TRUE(nlohmann::json::parse(rows[0].at("pass_ms")).contains("light0.testgood.fill"));
    // The light whose technique fell back is lit unshadowed: no pass of its own.
    EXPECT_EQ(nlohmann::json::parse(rows[1].at("pass_ms")), nlohmann::json::object());

    const nlohmann::json doc = nlohmann::json::parse(readFile(out / "results.json"));
    EXPECT_EQ(doc["frames"], 2);
    EXPECT_EQ(doc["warmup"], 1);
    EXPECT_EQ(doc["reference"]["technique"], "testgood");
    EXPECT_EQ(doc["reference"]["params"]["fill"], 0.75);
    EXPECT_EQ(doc["reference"]["renders"], 1) << "both variants share scene, camera and lights: one reference render";
    EXPECT_EQ(doc["argv"][1], "bench");
    EXPECT_TRUE(has(doc["command"].get<std::string>(), "bench")) << doc["command"];
    EXPECT_FALSE(doc["device"]["name"].get<std::string>().empty());
    EXPECT_GE(doc["machine"]["cpu_threads"].get<int>(), 0);
    ASSERT_EQ(doc["variants"].size(), 2u);
    for (size_t v = 0; v < 2; ++v) {
        const nlohmann::json& variant = doc["variants"][v];
        EXPECT_EQ(variant["choices"][0]["value"], v);
        ASSERT_EQ(variant["lights"].size(), 2u);
        std::set<std::string> passes;
        for (const nlohmann::json& p : variant["timing"]["passes"]) passes.insert(p["name"]);
        EXPECT_TRUE(passes.count("gbuffer") && passes.count("shading") && passes.count("light0.testgood.fill")) << variant.dump();
        const nlohmann::json& key = variant["lights"][0];
        EXPECT_NEAR(key["visibility"]["all"]["rmse"].get<double>(), v == 0 ? 0.5 : 0.25, kVStep);
        ASSERT_EQ(key["timing"]["passes"].size(), 1u);
        EXPECT_EQ(key["timing"]["passes"][0]["name"], "light0.testgood.fill");
        EXPECT_EQ(key["memory"]["bytes"], 0);
        // A panel's front is never empty; a panel of one point is its own front.
        EXPECT_TRUE(variant["lights"][1]["pareto_front"].get<bool>());
    }
    EXPECT_TRUE(doc["variants"][0]["lights"][0]["pareto_front"].get<bool>() ||
                doc["variants"][1]["lights"][0]["pareto_front"].get<bool>());

    const std::string svg = readFile(out / "pareto.svg");
    EXPECT_EQ(svg.rfind("<?xml", 0), 0u);
    EXPECT_TRUE(has(svg, "</svg>"));
    for (const char* text : {">light 'key'</text>", ">fill=0.25 · light 'fill'</text>", ">fill=0.5</text>", ">testgood</text>",
                             ">unshadowed</text>", "RMSE against the reference"}) {
        EXPECT_TRUE(has(svg, text)) << text;
    }
    EXPECT_TRUE(has(r.out, "2 variant(s) over 1 scene(s) built, medians of 2 frame(s) after 1 warm-up; reference testgood")) << r.out;

    // Every variant against its floor (apps/penumbra/FloorComparison.h): each pass with
    // the floor draw it is set against and the ratio of the two times; the frame's sum
    // against the shadowed floor frame (the key light has a technique).
    for (size_t v = 0; v < 2; ++v) {
        SCOPED_TRACE(v);
        const nlohmann::json& variant = doc["variants"][v];
        const nlohmann::json& floor = variant["floor"];
        EXPECT_TRUE(floor["shadowed"].get<bool>());
        EXPECT_TRUE(has(floor["rule"].get<std::string>(), "over the floor's forward draw")) << floor.dump();
        const double floorFrame = floor["floor_frame_ms"].get<double>();
        ASSERT_GT(floorFrame, 0.0);
        EXPECT_EQ(floorFrame, floor["shadowed_frame_ms"].get<double>());
        EXPECT_NEAR(floor["frame_multiple"].get<double>(), variant["timing"]["work_ms"].get<double>() / floorFrame, 1e-9);
        std::map<std::string, double> frameMs, floorMs;
        for (const nlohmann::json& p : variant["timing"]["passes"]) frameMs[p["name"]] = p["gpu_ms"].get<double>();
        for (const nlohmann::json& p : floor["floor_passes"]) floorMs[p["name"]] = p["gpu_ms"].get<double>();
        EXPECT_EQ(floorMs.size(), 4u) << floor.dump();  // two maps (key and fill), two forward draws
        ASSERT_EQ(floor["passes"].size(), frameMs.size());
        for (const nlohmann::json& p : floor["passes"]) {
            // Every pass of this frame writes an image of its size (G-buffer, V_l, shading).
            EXPECT_EQ(p["against"], "forward") << p.dump();
            EXPECT_EQ(p["floor_ms"].get<double>(), floorMs.at("floor.shadowed.forward")) << p.dump();
            EXPECT_NEAR(p["multiple"].get<double>(), frameMs.at(p["name"]) / p["floor_ms"].get<double>(), 1e-9) << p.dump();
        }
        EXPECT_EQ(std::stod(rows[2 * v].at("frame_floor_multiple")), floor["frame_multiple"].get<double>());
        EXPECT_EQ(std::stod(rows[2 * v].at("floor_frame_ms")), floorFrame);
    }
    EXPECT_TRUE(has(r.out, "against the floor (GPU ms of passes; x floor: a camera pass")) << r.out;
    EXPECT_TRUE(has(r.out, "shadowed floor frame")) << r.out;
}

TEST_F(Cli, BenchSummaryIsAMarkdownTablePerPanel)
{
    const fs::path cfg = dir / "cfg.json";
    nlohmann::json withNotes = nlohmann::json::parse(benchConfig());
    withNotes["notes"] = {"First *note*.", "Second note."};
    std::ofstream(cfg) << withNotes.dump();
    const fs::path summary = dir / "tradeoff.md";
    const CliResult r = run(fmt::format("bench '{}' {} --frames 1 --warmup 0 --summary '{}'", cfg.string(), kTestGoodReference,
                                        summary.string()),
                            pluginPath());
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_EQ(entryNames(dir), (std::set<std::string>{"cfg.json", "tradeoff.md", "stdout.txt", "stderr.txt"}))
        << "without -o only the summary is written";
    const std::string md = readFile(summary);
    EXPECT_EQ(md.rfind("# Speed–accuracy trade-off\n", 0), 0u) << md;
    for (const char* text : {"\n## light 'key'\n", "\n## fill=0.25 · light 'fill'\n", "\n## fill=0.5 · light 'fill'\n",
                             "| technique | variant | ms | memory | RMSE | RMSE penumbra | MAE | max | > 0.05 | > 0.2 | > 0.5 | SSIM | front |",
                             "| 0 B | 0.5000 | 0.5000 | 0.5000 | 0.500 | 100.00% | 100.00% | 0.00% | 0.6001 |",
                             "| 0 B | 0.2500 | 0.2500 | 0.2500 | 0.250 | 100.00% | 100.00% | 0.00% |", "| testgood | fill=0.25 |",
                             "| unshadowed | – |", "- reference: `testgood` `{", "- frames: 1 measured after 0 warm-up",
                             "Regenerate with:\n\n```sh\n", "\n## Against the floor\n",
                             "```\n\n## Notes\n\nFirst *note*.\n\nSecond note.\n\n## light 'key'\n",
                             "| variant | frame ms | floor frame ms | x floor | passes (x floor) |"}) {
        EXPECT_TRUE(has(md, text)) << text << "\n" << md;
    }
    EXPECT_TRUE(has(md, fmt::format("bench {} --reference testgood", cfg.string()))) << md;
}

TEST_F(Cli, BenchCreatesTheSummarysFolderAsItCreatesOutputs)
{
    // The summary beside the results: its folder does not exist until -o creates it.
    const fs::path cfg = dir / "cfg.json";
    std::ofstream(cfg) << benchConfig();
    const fs::path out = dir / "out";
    const CliResult r = run(fmt::format("bench '{}' {} --frames 1 --warmup 0 -o '{}' --summary '{}/summary.md'", cfg.string(),
                                        kTestGoodReference, out.string(), out.string()),
                            pluginPath());
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_EQ(entryNames(out), (std::set<std::string>{"results.csv", "results.json", "pareto.svg", "summary.md"}));
    EXPECT_TRUE(has(readFile(out / "summary.md"), "# Speed–accuracy trade-off\n"));
}

TEST_F(Cli, BenchRefusesBadInputBeforeRenderingOrWriting)
{
    const fs::path cfg = dir / "cfg.json";
    std::ofstream(cfg) << benchConfig();
    const fs::path out = dir / "out";
    const auto refused = [&](const std::string& config, const std::string& flags, const std::string& message, int code = 1) {
        const CliResult r = run(fmt::format("bench '{}' {} -o '{}'", config, flags, out.string()), pluginPath());
        if (code) EXPECT_EQ(r.exitCode, code) << flags;
        else EXPECT_NE(r.exitCode, 0) << flags;
        EXPECT_TRUE(has(r.err, message)) << flags << "\n" << r.err;
        EXPECT_FALSE(has(r.err, "variant 1/")) << "nothing rendered: " << r.err;
        EXPECT_FALSE(fs::exists(out)) << flags;
    };
    // Frames and warm-up: command-line usage errors that name the flag.
    refused(cfg.string(), kTestGoodReference + " --frames 0", "--frames", 0);
    refused(cfg.string(), kTestGoodReference + " --frames x", "--frames", 0);
    refused(cfg.string(), kTestGoodReference + " --warmup -1", "--warmup", 0);
    // The sweep: a path that sets nothing, a value its plugin refuses.
    const fs::path badPath = dir / "bad-path.json", badValue = dir / "bad-value.json";
    std::ofstream(badPath) << benchConfig(R"([{"path": "/lights/0/shadw/fill", "values": [0.25]}])");
    refused(badPath.string(), kTestGoodReference,
            "bad-path.json: /sweep/0/path: \"/lights/0/shadw/fill\": the config has no \"/lights/0/shadw\" to set it in");
    std::ofstream(badValue) << benchConfig(R"([{"path": "/lights/0/shadow/fill", "values": [0.25, 3]}])");
    refused(badValue.string(), kTestGoodReference,
            "bad-value.json (/sweep/0/values/1): /lights/0/shadow/fill: must be a number in [0, 1]");
    // The reference and --set.
    refused(cfg.string(), "--reference nosuch", "--reference nosuch: plugin 'nosuch': no file penumbra-nosuch.so");
    refused(cfg.string(), kTestGoodReference + " --set other.size=1",
            "--set other.size: no light of any sweep variant uses technique 'other'");
    refused(cfg.string(), kTestGoodReference + " --set testgood.kernel=99", "--set testgood.kernel: must be an integer in [1, 15]");
    // Outputs: a summary's folder that cannot be created (its parent missing; where no
    // folder can be made, even by root); -o a file or under a missing folder.
    refused(cfg.string(), kTestGoodReference + fmt::format(" --summary '{}/no/such/where.md'", dir.string()),
            fmt::format("--summary {0}/no/such/where.md (folder {0}/no/such): cannot create the folder: '{0}/no' does not exist",
                        dir.string()));
    refused(cfg.string(), kTestGoodReference + " --summary /proc/penumbra-summary/where.md",
            "--summary /proc/penumbra-summary/where.md (folder /proc/penumbra-summary): cannot create the folder: ");
    EXPECT_FALSE(fs::exists(dir / "no"));
    expectBadOutputFoldersRefused(fmt::format("bench '{}' {}", cfg.string(), kTestGoodReference), pluginPath());
    EXPECT_NE(run("bench").exitCode, 0) << "the config is required";
}

TEST_F(Cli, BenchReplacesItsOwnFilesAndLeavesOthersAlone)
{
    const fs::path cfg = dir / "cfg.json";
    std::ofstream(cfg) << benchConfig(R"([{"path": "/lights/0/shadow/fill", "values": [0.25]}])");
    const fs::path out = dir / "out";
    fs::create_directories(out);
    std::ofstream(out / "notes.txt") << "mine";
    std::ofstream(out / "results.csv") << "an older run";
    const CliResult r = run(fmt::format("bench '{}' {} --frames 1 -o '{}/'", cfg.string(), kTestGoodReference, out.string()),
                            pluginPath());
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_EQ(entryNames(out), (std::set<std::string>{"notes.txt", "results.csv", "results.json", "pareto.svg"}))
        << "no temporary file is left";
    EXPECT_EQ(readFile(out / "notes.txt"), "mine");
    EXPECT_EQ(csvRecords(readFile(out / "results.csv")).size(), 2u);
}

TEST_F(Cli, BenchSweepsTechniquesAndScenesWithOneReferencePerScene)
{
    // Two scenes, each with its own camera, times a real technique and the test one.
    // The reference is hard shadows at the swept hard variant's own settings: that
    // variant's error is exactly 0, and its shadow map is its memory.
    const fs::path cfg = dir / "cfg.json";
    std::ofstream(cfg) << R"({
        "scene": {"generator": "box-grid", "params": {"rows": 1, "columns": 1, "plane_size": 8}},
        "camera": {"position": [0, 5, 6], "target": [0, 0, 0]},
        "lights": [{"type": "spot", "position": [0.5, 4, 0.5], "target": [0, 0, 0], "outer_cone_deg": 50}],
        "output": {"width": 64, "height": 48},
        "sweep": [
          {"paths": ["/scene", "/camera"], "labels": ["grid", "occluder"], "values": [
            [{"generator": "box-grid", "params": {"rows": 1, "columns": 1, "plane_size": 8}}, {"position": [0, 5, 6], "target": [0, 0, 0]}],
            [{"generator": "penumbra"}, {"position": [2.5, 3, 3.5], "target": [0, 0, 0]}]]},
          {"path": "/lights/0/shadow", "labels": ["hard 128", "constant"], "values": [
            {"technique": "hard", "resolution": 128}, {"technique": "testgood", "fill": 1}]}]})";
    const fs::path out = dir / "out";
    const CliResult r = run(fmt::format("bench '{}' --reference hard --reference-set resolution=128 --frames 1 -o '{}' --validation",
                                        cfg.string(), out.string()),
                            pluginPath());
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const nlohmann::json doc = nlohmann::json::parse(readFile(out / "results.json"));
    EXPECT_EQ(doc["reference"]["renders"], 2) << "one reference per scene, shared by both techniques";
    EXPECT_EQ(doc["scenes_built"], 2) << "one per scene source, shared by both techniques";
    EXPECT_TRUE(has(r.out, "4 variant(s) over 2 scene(s) built")) << r.out;
    ASSERT_EQ(doc["variants"].size(), 4u);
    for (size_t v = 0; v < 4; ++v) {
        SCOPED_TRACE(v);
        const nlohmann::json& variant = doc["variants"][v];
        const nlohmann::json& light = variant["lights"][0];
        const bool hard = v % 2 == 0;
        EXPECT_EQ(variant["scene"], v < 2 ? "box-grid" : "penumbra");
        EXPECT_EQ(light["context"], v < 2 ? "grid" : "occluder");
        EXPECT_EQ(light["technique_label"], hard ? "hard 128" : "constant");
        EXPECT_EQ(light["technique"], hard ? "hard" : "testgood");
        if (hard) {
            EXPECT_EQ(light["visibility"]["all"]["rmse"], 0.0);
            EXPECT_TRUE(light["pareto_front"].get<bool>()) << "nothing beats an exact match";
            EXPECT_GE(light["memory"]["bytes"].get<uint64_t>(), 128u * 128u * 4u) << "the 128^2 D32 shadow map";
            for (const nlohmann::json& resource : light["memory"]["resources"]) {
                EXPECT_EQ(resource["name"].get<std::string>().rfind("light0.hard.", 0), 0u) << resource;
            }
        } else {
            EXPECT_GT(light["visibility"]["all"]["rmse"].get<double>(), 0.0) << "V = 1 misses the shadow";
            EXPECT_EQ(light["memory"]["bytes"], 0);
        }
    }
    const std::string svg = readFile(out / "pareto.svg");
    EXPECT_TRUE(has(svg, ">grid · light 'light0'</text>")) << svg;
    EXPECT_TRUE(has(svg, ">occluder · light 'light0'</text>")) << svg;
    EXPECT_TRUE(has(svg, ">hard 128</text>")) << svg;
}

TEST_F(Cli, BenchCountsAHostPassAsTheTechniquesTime)
{
    // The ray-traced reference as the technique under test: its tracing is a host pass,
    // whose CPU time is part of the technique's time; against itself, no error.
    const fs::path cfg = dir / "cfg.json";
    std::ofstream(cfg) << R"({
        "scene": {"generator": "penumbra"},
        "camera": {"position": [2.5, 3, 3.5], "target": [0, 0, 0]},
        "lights": [{"type": "rect", "position": [0, 3, 0], "direction": [0, -1, 0], "size": [0.5, 0.5]}],
        "output": {"width": 32, "height": 24},
        "sweep": [{"path": "/lights/0/shadow", "labels": ["traced"], "values": [{"technique": "reference", "samples": 4, "cache": false}]}]})";
    const fs::path out = dir / "out";
    const CliResult r = run(fmt::format("bench '{}' --reference-set samples=4 --reference-set cache=false --frames 1 --warmup 0 "
                                        "-o '{}' --validation",
                                        cfg.string(), out.string()));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const nlohmann::json light = nlohmann::json::parse(readFile(out / "results.json"))["variants"][0]["lights"][0];
    EXPECT_EQ(light["technique"], "reference");
    EXPECT_EQ(light["visibility"]["all"]["rmse"], 0.0) << "same samples, same seed";
    std::map<std::string, bool> host;
    for (const nlohmann::json& pass : light["timing"]["passes"]) host[pass["name"]] = pass["host"];
    EXPECT_EQ(host, (std::map<std::string, bool>{{"light0.reference.read_gbuffer", false},
                                                 {"light0.reference.trace", true},
                                                 {"light0.reference.upload", false}}));
    const nlohmann::json& t = light["timing"];
    EXPECT_EQ(t["work_ms"].get<double>(), t["gpu_ms"].get<double>() + t["host_ms"].get<double>()) << "one frame: exact";
    const std::vector<std::map<std::string, std::string>> rows = csvRecords(readFile(out / "results.csv"));
    ASSERT_EQ(rows.size(), 1u);
    EXPECT_TRUE(nlohmann::json::parse(rows[0].at("pass_ms")).contains("light0.reference.trace"));
}

TEST_F(Cli, BenchInterruptedWritesNothing)
{
    const fs::path cfg = dir / "cfg.json";
    std::ofstream(cfg) << benchConfig(R"([{"path": "/lights/0/shadow/fill", "values": [0.25]}])");
    const fs::path out = dir / "out", err = dir / "bench-err.txt", code = dir / "code.txt";
    // Started in the background; once it is rendering, SIGTERM. It stops after the frame
    // in flight, through the normal unwinding.
    const std::string script = fmt::format(
        "{} '{}' bench '{}' {} --frames 100000 -o '{}' 2> '{}' > /dev/null < /dev/null & pid=$!; "
        "for i in $(seq 1 600); do grep -q 'variant 1/1' '{}' && break; sleep 0.1; done; sleep 0.5; "
        "kill -TERM $pid; wait $pid; echo $? > '{}'",
        pluginPath(), penumbra::test::penumbraExecutable().string(), cfg.string(), kTestGoodReference, out.string(), err.string(), err.string(), code.string());
    ASSERT_EQ(std::system(script.c_str()), 0);
    EXPECT_EQ(readFile(code), "143\n") << readFile(err);
    EXPECT_TRUE(has(readFile(err), "penumbra: interrupted after 0 of 1 variant(s); nothing written")) << readFile(err);
    EXPECT_FALSE(fs::exists(out));
}

// --animate: every measured frame is posed at its own time, with a reference render per
// pose; without it, every frame shows frame 0 and one reference serves them all.
TEST_F(Cli, BenchAnimateWalksTheAnimationWithAReferencePerPose)
{
    const fs::path cfg = dir / "cfg.json";
    std::ofstream(cfg) << fmt::format(
        R"({{"include": {}, "output": {{"width": 48, "height": 32}},
            "animation": {{"fps": 2, "tracks": [{{"target": "/camera/position",
              "keys": [{{"t": 0, "value": [15, 11, 17]}}, {{"t": 2, "value": [-4, 9, 21]}}]}}]}},
            "sweep": [{{"path": "/lights/0/shadow/resolution", "values": [256]}}]}})",
        nlohmann::json(penumbra::test::sourceDir().string() + "/config/default.json").dump());
    const auto bench = [&](const std::string& flags, const fs::path& out) {
        const CliResult r = run(fmt::format("bench '{}' --frames 3 --warmup 1 --reference-set samples=1 -o '{}' {}",
                                            cfg.string(), out.string(), flags),
                                pluginPath());
        EXPECT_EQ(r.exitCode, 0) << r.err;
        return r.out;
    };
    const std::string still = bench("", dir / "still"), walked = bench("--animate", dir / "walked");
    EXPECT_TRUE(has(still, "(1 render(s))")) << still;
    EXPECT_TRUE(has(walked, "(3 render(s))")) << walked;  // the measured frames 1, 2, 3
    const nlohmann::json a = nlohmann::json::parse(readFile(dir / "still" / "results.json"));
    const nlohmann::json b = nlohmann::json::parse(readFile(dir / "walked" / "results.json"));
    EXPECT_EQ(a["animated"], false);
    EXPECT_EQ(b["animated"], true);
    // Three frames of pixels against one frame's.
    const auto pixels = [](const nlohmann::json& j) {
        return j["variants"][0]["lights"][0]["visibility"]["all"]["pixels"].get<uint64_t>();
    };
    EXPECT_GT(pixels(b), 2 * pixels(a));
}
