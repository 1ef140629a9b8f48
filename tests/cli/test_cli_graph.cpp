// `penumbra graph`: the frame's render graph as text or Graphviz.
#include "CliTest.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

using namespace penumbra::test;
namespace fs = std::filesystem;

TEST_F(Cli, GraphPrintsPassesInOrderResourcesAndMemory)
{
    const CliResult r = run(fmt::format("graph {} --width 160 --height 90 --validation", config("two-spots.json")));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    // The engine's passes frame each light's technique passes.
    const size_t gbuffer = r.out.find("gbuffer (graphics)");
    const size_t light0 = r.out.find("light0.hard.");
    const size_t light1 = r.out.find("light1.hard.");
    const size_t shading = r.out.find("shading (compute)");
    ASSERT_NE(gbuffer, std::string::npos) << r.out;
    ASSERT_NE(light0, std::string::npos) << r.out;
    ASSERT_NE(light1, std::string::npos) << r.out;
    ASSERT_NE(shading, std::string::npos) << r.out;
    EXPECT_LT(gbuffer, light0);
    EXPECT_LT(light1, shading);
    // The frame `render` draws: nothing but shading reads V, so shading evaluates hard's
    // visibility function and reads the maps; no visibility pass, no visibility image.
    EXPECT_NE(r.out.find("visibility evaluated in shading, no image (render --visibility-exr or --debug-image keeps "
                         "one): light 0 (hard), light 1 (hard)"),
              std::string::npos)
        << r.out;
    EXPECT_EQ(r.out.find("light0.hard.visibility"), std::string::npos) << r.out;
    // Each light shaded over its screen bounds only: the sky is no light's.
    const size_t regions = r.out.find("shading: ");
    ASSERT_NE(regions, std::string::npos) << r.out;
    const std::string line = r.out.substr(regions, r.out.find('\n', regions) - regions);
    EXPECT_NE(line.find("rectangle(s); each light added over its screen bounds, share of the pixels: light 0 "), std::string::npos)
        << line;
    EXPECT_EQ(line.find("100.0%"), std::string::npos) << line;
    EXPECT_EQ(r.out.find("light0.visibility: image"), std::string::npos) << r.out;
    EXPECT_GT(r.out.find("barrier 'light1.hard.shadow_map' DepthAttachmentOptimal -> DepthReadOnlyOptimal"), shading)
        << r.out;
    // What may be kept from frame to frame, and on what it depends (keep_unchanged).
    EXPECT_NE(r.out.find("light0.hard.shadow_map (graphics), kept while light0 unchanged"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("shading (compute), kept while camera, lights unchanged"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("device memory for transient resources:"), std::string::npos) << r.out;
    // The names `render --debug-image` takes, each light's maps among them.
    const size_t debug = r.out.find("debug images (penumbra render --debug-image NAME): ");
    ASSERT_NE(debug, std::string::npos) << r.out;
    const std::string names = r.out.substr(debug, r.out.find('\n', debug) - debug);
    for (const char* name : {"gbuffer.depth", "light0.hard.shadow_map", "light1.hard.shadow_map", "light1.visibility", "color"})
        EXPECT_NE(names.find(name), std::string::npos) << name << "\n" << names;
}

TEST_F(Cli, GraphSaysCullingRunsOutsideTheGraph)
{
    const fs::path cfg = dir / "culled.json";
    std::ofstream(cfg) << fmt::format(R"({{"include": "{}/config/default.json", "culling": "receiver-mask"}})",
                                      penumbra::test::sourceDir().string());
    const CliResult r = run(fmt::format("graph '{}' --width 160 --height 90", cfg.string()));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const size_t section = r.out.find("outside the graph: culling receiver-mask");
    ASSERT_NE(section, std::string::npos) << r.out;
    EXPECT_LT(r.out.find("shading (compute)"), section) << "after the passes";
    for (const char* figure : {"camera culling ms", "receiver masks ms", "caster culling ms", "query rounds"})
        EXPECT_NE(r.out.find(figure, section), std::string::npos) << figure << "\n" << r.out;
}

TEST_F(Cli, GraphWritesGraphvizToAFile)
{
    const fs::path dot = dir / "frame.dot";
    const CliResult r = run(fmt::format("graph {} --format dot -o '{}' --width 160 --height 90", config("default.json"),
                                        dot.string()));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const std::string text = readFile(dot);
    EXPECT_EQ(text.rfind("digraph render_graph {", 0), 0u) << text;
    EXPECT_NE(text.find("\"pass:shading\""), std::string::npos);
    EXPECT_NE(text.find("\"res:light0.hard.shadow_map\" -> \"pass:shading\""), std::string::npos) << text;
}

TEST_F(Cli, GraphRejectsABadFormat)
{
    const CliResult r = run(fmt::format("graph {} --format svg", config("default.json")));
    EXPECT_NE(r.exitCode, 0);
    EXPECT_NE(r.err.find("svg"), std::string::npos) << r.err;
}
