// pareto.svg of `penumbra bench` (apps/penumbra/ParetoPlot.h, PlotLabels.h; issue 43 item 9):
// labels never overlap each other, a point or a line; and the document draws every point
// and spread mark in its colour through ImageMagick's own renderer and librsvg alike.
// Made from results written here, without a device; compiled into the unit tests.
#include "ScratchFolder.h"

#include "ParetoPlot.h"
#include "PlotLabels.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <stb/stb_image.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <regex>

using namespace penumbra;
namespace fs = std::filesystem;

namespace {

constexpr app::PlotBox kFrame{72, 34, 616, 368};

// Every label inside the frame, clear of every other label and of every point's disc;
// `clear`: also of every line (PlacedLabel::clear).
void expectApart(const std::vector<app::PlacedLabel>& labels, const std::vector<std::pair<double, double>>& points, double radius,
                 bool clear)
{
    for (size_t i = 0; i < labels.size(); ++i) {
        SCOPED_TRACE(i);
        const app::PlotBox& b = labels[i].box;
        if (clear) {
            EXPECT_TRUE(labels[i].clear);
        }
        EXPECT_TRUE(kFrame.contains(b)) << b.x0 << ", " << b.y0 << " .. " << b.x1 << ", " << b.y1;
        for (size_t j = 0; j < i; ++j) EXPECT_FALSE(b.overlaps(labels[j].box)) << "overlaps label " << j;
        for (const auto& [x, y] : points) EXPECT_FALSE(b.overlaps({x - radius, y - radius, x + radius, y + radius})) << x << ", " << y;
    }
}

TEST(PlotLabels, LabelsOfOnePlaceStackApartWithLeaders)
{
    // Twelve variants with equal time and error (a sweep over a parameter that changes
    // nothing): one spot, twelve long labels.
    app::LabelPlacer placer(kFrame, 10);
    const std::vector<std::pair<double, double>> points(12, {300.0, 200.0});
    for (const auto& [x, y] : points) placer.addPoint(x, y, 4.5);
    std::vector<app::PlacedLabel> labels;
    for (size_t i = 0; i < points.size(); ++i) {
        labels.push_back(placer.place(points[i].first, points[i].second, 4.5, fmt::format("resolution={}, slope_bias=2.0", 512 << i)));
    }
    expectApart(labels, points, 4.5, true);
    EXPECT_FALSE(labels[0].leader) << "the first label sits right beside its point";
    EXPECT_LT(labels[0].box.x0 - 300.0, 10.0);
    size_t leaders = 0;
    for (const app::PlacedLabel& l : labels) leaders += l.leader ? 1 : 0;
    EXPECT_GT(leaders, 0u) << "twelve labels cannot all touch one point";
    for (const app::PlacedLabel& l : labels) {
        if (!l.leader) continue;
        // The leader runs from the point's disc to the label's box.
        EXPECT_NEAR(std::hypot(l.leaderX0 - 300.0, l.leaderY0 - 200.0), 5.5, 1e-9);
        EXPECT_GE(l.leaderX1, l.box.x0 - 1e-9);
        EXPECT_LE(l.leaderX1, l.box.x1 + 1e-9);
        EXPECT_GE(l.leaderY1, l.box.y0 - 1e-9);
        EXPECT_LE(l.leaderY1, l.box.y1 + 1e-9);
    }
}

TEST(PlotLabels, DenseCornerKeepsTextApart)
{
    // A cluster in the frame's top-right corner (fast and exact is never there; slow and
    // wrong is) with a line through it: the labels of points walled in by their
    // neighbours cannot all be clear of lines, but text never covers text or a point.
    app::LabelPlacer placer(kFrame, 10);
    std::vector<std::pair<double, double>> points;
    for (int i = 0; i < 9; ++i) points.push_back({600.0 - 14.0 * (i % 3), 42.0 + 14.0 * (i / 3)});
    for (const auto& [x, y] : points) placer.addPoint(x, y, 4.5);
    placer.addSegment(450.0, 30.0, 610.0, 120.0);
    std::vector<app::PlacedLabel> labels;
    for (const auto& [x, y] : points) labels.push_back(placer.place(x, y, 4.5, "pcss blocker_samples=16, pcf=25"));
    expectApart(labels, points, 4.5, false);
}

TEST(PlotLabels, LabelsAvoidLines)
{
    // A line where the nearest spot would be: the label moves off it.
    app::LabelPlacer placer(kFrame, 10);
    placer.addPoint(300.0, 200.0, 4.5);
    placer.addSegment(300.0, 200.0, 500.0, 200.0);
    const app::PlacedLabel label = placer.place(300.0, 200.0, 4.5, "hard 2048");
    expectApart({label}, {{300.0, 200.0}}, 4.5, true);
    EXPECT_FALSE(label.box.crosses(300.0, 200.0, 500.0, 200.0));
    EXPECT_FALSE(label.leader) << "a clear spot right beside the point";
}

TEST(PlotLabels, BoxGeometry)
{
    const app::PlotBox box{10, 10, 20, 20};
    EXPECT_TRUE(box.crosses(0, 15, 30, 15));
    EXPECT_TRUE(box.crosses(12, 12, 14, 14)) << "inside";
    EXPECT_FALSE(box.crosses(0, 0, 30, 5)) << "above";
    EXPECT_FALSE(box.crosses(0, 15, 15, 0)) << "past the corner";
    EXPECT_TRUE(box.crosses(0, 25, 25, 0)) << "diagonally through";
    EXPECT_FALSE(box.overlaps({20, 10, 30, 20})) << "edges touch";
    EXPECT_TRUE(box.overlaps({19, 19, 30, 30}));
    // One UTF-8 character is one character wide; wide letters are wider.
    EXPECT_DOUBLE_EQ(app::estimateTextWidth("a·b", 10), app::estimateTextWidth("axb", 10));
    EXPECT_GT(app::estimateTextWidth("mmmm", 10), app::estimateTextWidth("iiii", 10));
}

// One panel: a light under four shadow settings of two techniques, timed over three
// frames; `spread` gives each its min–max.
app::BenchRun fourPoints()
{
    app::BenchRun run;
    run.config = "plot.json";
    run.device = {{"name", "test device"}};
    run.frames = 3;
    run.reference = "reference";
    const struct {
        const char* technique;
        const char* label;
        double ms, minMs, maxMs, rmse;
    } kPoints[] = {{"hard", "hard 512", 2.0, 1.5, 3.0, 0.09},
                   {"hard", "hard 2048", 8.0, 8.0, 8.0, 0.04},
                   {"pcss", "pcss 16", 20.0, 12.0, 40.0, 0.02},
                   {"pcss", "pcss 64", 60.0, 55.0, 70.0, 0.015}};
    for (const auto& p : kPoints) {
        app::BenchVariant v;
        v.index = run.variants.size();
        v.label = p.label;
        app::BenchLight l;
        l.name = "sun";
        l.technique = p.technique;
        l.techniqueLabel = p.label;
        l.params = nlohmann::json::object();
        l.timing.frames = 3;
        l.timing.workMs = p.ms;
        l.timing.workMinMs = p.minMs;
        l.timing.workMaxMs = p.maxMs;
        l.visibility.all.rmse = p.rmse;
        v.lights.push_back(l);
        run.variants.push_back(v);
    }
    app::markParetoFronts(run);
    return run;
}

struct Rgb {
    int r, g, b;
};
Rgb hexColor(const std::string& hex) { return {std::stoi(hex.substr(1, 2), nullptr, 16), std::stoi(hex.substr(3, 2), nullptr, 16), std::stoi(hex.substr(5, 2), nullptr, 16)}; }

struct Mark {
    double x, y;
    Rgb color;
};

// Where the document draws each point's disc (its centre) and each spread mark (a
// pixel inside its bar, clear of the point), with their colours, read from the SVG.
void findMarks(const std::string& svg, std::vector<Mark>& discs, std::vector<Mark>& bars)
{
    const std::regex disc(R"re(<g><title>[^<]*</title><circle cx="([0-9.]+)" cy="([0-9.]+)" r="4.5" fill="(#[0-9A-Fa-f]{6})")re");
    for (auto it = std::sregex_iterator(svg.begin(), svg.end(), disc); it != std::sregex_iterator(); ++it)
        discs.push_back({std::stod((*it)[1]), std::stod((*it)[2]), hexColor((*it)[3])});
    const std::regex bar(R"re(<path d="M ([0-9.]+) ([0-9.]+) H ([0-9.]+) [^"]*" fill="none" stroke="(#[0-9A-Fa-f]{6})")re");
    for (auto it = std::sregex_iterator(svg.begin(), svg.end(), bar); it != std::sregex_iterator(); ++it)
        bars.push_back({std::stod((*it)[1]) + 2.0, std::stod((*it)[2]), hexColor((*it)[4])});
}

bool hasProgram(const char* path) { return ::access(path, X_OK) == 0; }

TEST(ParetoPlot, ConvertersDrawEveryPointInItsColour)
{
    // ImageMagick's own SVG renderer (the MSVG coder, from libmagickcore-6.q16-6-extra)
    // and librsvg's rsvg-convert: .ci/install-deps.sh installs both.
    if (!hasProgram("/usr/bin/convert") || !hasProgram("/usr/bin/rsvg-convert") ||
        std::system("/usr/bin/convert -list format 2>/dev/null | grep -q MSVG") != 0) {
        GTEST_SKIP() << "needs ImageMagick with its SVG coder and rsvg-convert (apt-get install imagemagick "
                        "libmagickcore-6.q16-6-extra librsvg2-bin)";
    }
    const fs::path dir = test::makeScratchFolder("pareto");
    const std::string svg = app::paretoSvg(fourPoints());
    std::ofstream(dir / "pareto.svg") << svg;
    std::vector<Mark> discs, bars;
    findMarks(svg, discs, bars);
    ASSERT_EQ(discs.size(), 4u) << svg;
    ASSERT_EQ(bars.size(), 4u) << "three spread marks and the legend's: " << svg;

    for (const auto& [name, command] :
         {std::pair<const char*, std::string>{"ImageMagick", "/usr/bin/convert 'msvg:{0}/pareto.svg' '{0}/{1}.png'"},
          {"rsvg-convert", "/usr/bin/rsvg-convert '{0}/pareto.svg' -o '{0}/{1}.png'"}}) {
        SCOPED_TRACE(name);
        ASSERT_EQ(std::system(fmt::format(fmt::runtime(command + " 2>/dev/null"), dir.string(), name).c_str()), 0);
        int w = 0, h = 0, n = 0;
        unsigned char* pixels = stbi_load((dir / (std::string(name) + ".png")).c_str(), &w, &h, &n, 3);
        ASSERT_NE(pixels, nullptr);
        EXPECT_EQ(w, 640);
        const auto pixel = [&](double x, double y) {
            EXPECT_TRUE(x >= 0 && y >= 0 && x < w && y < h) << x << ", " << y;
            const unsigned char* p = pixels + 3 * (size_t(std::clamp(int(y), 0, h - 1)) * size_t(w) + size_t(std::clamp(int(x), 0, w - 1)));
            return Rgb{p[0], p[1], p[2]};
        };
        const auto distance = [](Rgb a, Rgb b) { return std::hypot(a.r - b.r, a.g - b.g, a.b - b.b); };
        for (const Mark& m : discs) {
            // A disc's centre is its colour (antialiasing aside).
            const Rgb p = pixel(m.x, m.y);
            EXPECT_LT(distance(p, m.color), 40.0) << "point at " << m.x << ", " << m.y << ": " << p.r << " " << p.g << " " << p.b;
        }
        for (const Mark& m : bars) {
            // A bar 1.2 px high covers no pixel row whole: the row under its centre holds
            // more of its colour than of the white behind.
            const Rgb p = pixel(m.x, m.y);
            EXPECT_LT(distance(p, m.color), distance(p, {255, 255, 255}))
                << "spread mark at " << m.x << ", " << m.y << ": " << p.r << " " << p.g << " " << p.b;
        }
        stbi_image_free(pixels);
    }
    fs::remove_all(dir);
}

TEST(ParetoPlot, SpreadOnlyWhereTheFramesDiffer)
{
    app::BenchRun run = fourPoints();
    std::vector<Mark> discs, bars;
    findMarks(app::paretoSvg(run), discs, bars);
    EXPECT_EQ(bars.size(), 4u) << "hard 2048's frames were equal: no mark; the legend has one";
    for (app::BenchVariant& v : run.variants) v.lights[0].timing.frames = 1;
    discs.clear();
    bars.clear();
    findMarks(app::paretoSvg(run), discs, bars);
    EXPECT_EQ(discs.size(), 4u);
    EXPECT_EQ(bars.size(), 0u) << "one frame has no spread";
}

} // namespace
