#include "ParetoPlot.h"

#include "PlotLabels.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>

namespace penumbra::app {
namespace {

// Okabe & Ito's colour-blind-safe palette, without its yellow (too pale on white).
constexpr const char* kTechniqueColors[] = {"#0072B2", "#D55E00", "#009E73", "#CC79A7", "#56B4E9", "#E69F00", "#000000"};

constexpr double kPanelWidth = 640, kPanelHeight = 420;
constexpr double kHeaderHeight = 84;
// The axes frame inside a panel.
constexpr double kLeft = 72, kRight = 24, kTop = 34, kBottom = 52;

std::string xmlText(const std::string& text)
{
    std::string out;
    for (char c : text) {
        switch (c) {
        case '&': out += "&amp;"; break;
        case '<': out += "&lt;"; break;
        case '>': out += "&gt;"; break;
        case '"': out += "&quot;"; break;
        default: out += c;
        }
    }
    return out;
}

// 1, 2 or 5 times a power of ten, near `x` (> 0).
double niceStep(double x)
{
    const double decade = std::pow(10.0, std::floor(std::log10(x)));
    const double f = x / decade;
    return (f < 1.5 ? 1.0 : f < 3.0 ? 2.0 : f < 7.0 ? 5.0 : 10.0) * decade;
}

struct Axis {
    double lo = 0.0, hi = 1.0;
    bool log = false;
    std::vector<double> ticks;

    // 0 at lo, 1 at hi.
    double fraction(double v) const
    {
        return log ? (std::log10(v) - std::log10(lo)) / (std::log10(hi) - std::log10(lo)) : (v - lo) / (hi - lo);
    }
};

// From 0 to a round number above the largest value, about five ticks. All zero (a
// technique without timestamps, a perfect match): 0 to 1, never a zero-length axis.
Axis linearAxis(double largest)
{
    Axis axis;
    const double top = largest > 0.0 && std::isfinite(largest) ? largest * 1.05 : 1.0;
    const double step = niceStep(top / 5.0);
    const double steps = std::ceil(top / step);
    axis.hi = steps * step;
    for (double i = 0.0; i <= steps; ++i) axis.ticks.push_back(i * step);
    return axis;
}

// From the largest 1, 2 or 5 times a power of ten at or below the smallest value to the
// smallest one at or above the largest; ticks at 1, 2 and 5 of each decade when the axis
// spans few decades, else at whole decades.
Axis logAxis(double smallest, double largest)
{
    constexpr double kSteps[] = {1.0, 2.0, 5.0};
    Axis axis;
    axis.log = true;
    const double loDecade = std::pow(10.0, std::floor(std::log10(smallest)));
    for (double step : kSteps)
        if (step * loDecade <= smallest) axis.lo = step * loDecade;
    const double hiDecade = std::pow(10.0, std::floor(std::log10(largest)));
    axis.hi = 10.0 * hiDecade;
    for (double step : {5.0, 2.0, 1.0})
        if (step * hiDecade >= largest) axis.hi = step * hiDecade;
    const bool fewDecades = axis.hi / axis.lo <= 1000.0;
    for (double decade = loDecade; decade <= axis.hi * (1.0 + 1e-9); decade *= 10.0) {
        for (double step : kSteps) {
            const double t = step * decade;
            if ((fewDecades || step == 1.0) && t >= axis.lo * (1.0 - 1e-9) && t <= axis.hi * (1.0 + 1e-9)) axis.ticks.push_back(t);
        }
    }
    return axis;
}

// Log when the times are all > 0 and span a factor of 10 or more: otherwise a log axis
// would either hide a zero or stretch a narrow range.
Axis timeAxis(const std::vector<double>& times)
{
    if (times.empty()) return linearAxis(0.0);
    const auto [lo, hi] = std::minmax_element(times.begin(), times.end());
    if (*lo > 0.0 && *hi / *lo >= 10.0) return logAxis(*lo, *hi);
    return linearAxis(*hi);
}

// Presentation attributes, never a <style> sheet: ImageMagick's own SVG renderer ignores a
// sheet's fonts and sizes.
struct TextStyle {
    double px;
    const char* fill;
    bool bold;
};
constexpr TextStyle kTitleText{15, "#222", true}, kPanelText{13, "#222", true}, kAxisText{12, "#222", false},
    kTickText{10, "#555", false}, kLabelText{10, "#222", false};

constexpr double kPointRadius = 4.5;
constexpr double kSpreadCap = 3.5;  // half the height of a spread mark's end caps

// A <text> at (x, y), or placed by `transform` when one is given.
std::string svgText(double x, double y, const TextStyle& style, const char* anchor, const std::string& text,
                    const std::string& transform = {})
{
    const std::string where = transform.empty() ? fmt::format("x=\"{:.1f}\" y=\"{:.1f}\"", x, y)
                                                : fmt::format("transform=\"{}\"", transform);
    return fmt::format("<text {} font-family=\"sans-serif\" font-size=\"{}\"{} fill=\"{}\" text-anchor=\"{}\">{}</text>\n", where,
                       style.px, style.bold ? " font-weight=\"bold\"" : "", style.fill, anchor, xmlText(text));
}

// A horizontal bar from x0 to x1 at y with end caps: a median's min–max over the frames.
std::string spreadMark(double x0, double x1, double y, const std::string& color)
{
    return fmt::format("<path d=\"M {0:.1f} {2:.1f} H {1:.1f} M {0:.1f} {3:.1f} V {4:.1f} M {1:.1f} {3:.1f} V {4:.1f}\" "
                       "fill=\"none\" stroke=\"{5}\" stroke-width=\"1.2\"/>\n",
                       x0, x1, y, y - kSpreadCap, y + kSpreadCap, color);
}

std::string pointMarker(double x, double y, const std::string& color, bool onFront, const std::string& title)
{
    // The tooltip's <title> belongs to a group around the disc, not to the disc itself:
    // ImageMagick's renderer drops a shape that has a child.
    return fmt::format("<g><title>{}</title><circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"{}\" fill=\"{}\" stroke=\"{}\" "
                       "stroke-width=\"{}\"/></g>\n",
                       xmlText(title), x, y, kPointRadius, color, onFront ? "#000" : "#fff", onFront ? 1.5 : 1.0);
}

constexpr const char* kFrontStroke = "fill=\"none\" stroke=\"#444\" stroke-width=\"1.5\" stroke-dasharray=\"5 3\"";

// The document in two layers, shapes then text: ImageMagick's renderer stops drawing at a
// text whose font it cannot load (a system without its fonts), so every shape comes first.
struct SvgLayers {
    std::string shapes, text;
};

// A light's time spread is drawn when it has one: more than one frame, not all equal.
bool hasSpread(const TimingSummary& t) { return t.frames > 1 && t.workMaxMs > t.workMinMs; }

struct Point {
    double x = 0.0, y = 0.0;  // ms, RMSE
    const BenchLight* light = nullptr;
    const BenchVariant* variant = nullptr;
};

std::string pointTitle(const Point& p)
{
    const BenchLight& l = *p.light;
    const std::string spread =
        hasSpread(l.timing) ? fmt::format(" (min {:.4g}, max {:.4g} over {} frames)", l.timing.workMinMs, l.timing.workMaxMs, l.timing.frames)
                            : "";
    return fmt::format("{}: {} {}; {:.4g} ms{}, RMSE {:.4g}{}", p.variant->label.empty() ? "the config" : p.variant->label,
                       l.technique, l.params.dump(), p.x, spread, p.y, l.paretoFront ? " (Pareto front)" : "");
}

void drawPanel(const TradeoffPanel& panel, const BenchRun& run, double ox, double oy, const std::map<std::string, std::string>& colors,
               SvgLayers& svg)
{
    std::vector<Point> points;
    std::vector<double> times, errors;
    for (const TradeoffPanel::Member& m : panel.members) {
        const BenchVariant& v = run.variants[m.variant];
        const BenchLight& l = v.lights[m.light];
        points.push_back({l.timing.workMs, l.visibility.all.rmse, &l, &v});
        times.push_back(l.timing.workMs);
        if (hasSpread(l.timing)) times.insert(times.end(), {l.timing.workMinMs, l.timing.workMaxMs});
        errors.push_back(l.visibility.all.rmse);
    }
    const Axis x = timeAxis(times);
    const Axis y = linearAxis(errors.empty() ? 0.0 : *std::max_element(errors.begin(), errors.end()));
    const double left = ox + kLeft, right = ox + kPanelWidth - kRight, top = oy + kTop, bottom = oy + kPanelHeight - kBottom;
    const auto px = [&](double v) { return left + x.fraction(v) * (right - left); };
    const auto py = [&](double v) { return bottom - y.fraction(v) * (bottom - top); };

    svg.text += svgText(left, oy + 20, kPanelText, "start", panel.title);
    for (double t : x.ticks) {
        svg.shapes += fmt::format("<line x1=\"{0:.1f}\" y1=\"{1:.1f}\" x2=\"{0:.1f}\" y2=\"{2:.1f}\" stroke=\"#e4e4e4\"/>\n", px(t),
                                  top, bottom);
        svg.text += svgText(px(t), bottom + 16, kTickText, "middle", fmt::format("{:g}", t));
    }
    for (double t : y.ticks) {
        svg.shapes += fmt::format("<line x1=\"{0:.1f}\" y1=\"{2:.1f}\" x2=\"{1:.1f}\" y2=\"{2:.1f}\" stroke=\"#e4e4e4\"/>\n", left,
                                  right, py(t));
        svg.text += svgText(left - 6, py(t) + 4, kTickText, "end", fmt::format("{:g}", t));
    }
    svg.shapes += fmt::format("<rect x=\"{:.1f}\" y=\"{:.1f}\" width=\"{:.1f}\" height=\"{:.1f}\" fill=\"none\" stroke=\"#888\"/>\n",
                              left, top, right - left, bottom - top);
    svg.text += svgText(0.5 * (left + right), oy + kPanelHeight - 14, kAxisText, "middle",
                        fmt::format("technique ms{}", x.log ? " (log scale)" : ""));
    svg.text += svgText(0, 0, kAxisText, "middle", "RMSE against the reference",
                        fmt::format("translate({:.1f} {:.1f}) rotate(-90)", ox + 18, 0.5 * (top + bottom)));

    LabelPlacer labels({left, top, right, bottom}, kLabelText.px);
    // The front first, under the points: its points ordered by time (error falls along it).
    std::vector<const Point*> front;
    for (const Point& p : points)
        if (p.light->paretoFront) front.push_back(&p);
    std::sort(front.begin(), front.end(), [](const Point* a, const Point* b) { return a->x != b->x ? a->x < b->x : a->y < b->y; });
    if (front.size() > 1) {
        std::string coords;
        for (size_t i = 0; i < front.size(); ++i) {
            coords += fmt::format("{:.1f},{:.1f} ", px(front[i]->x), py(front[i]->y));
            if (i > 0) labels.addSegment(px(front[i - 1]->x), py(front[i - 1]->y), px(front[i]->x), py(front[i]->y));
        }
        svg.shapes += fmt::format("<polyline points=\"{}\" {}/>\n", coords, kFrontStroke);
    }
    for (const Point& p : points) {
        const TimingSummary& t = p.light->timing;
        if (!hasSpread(t)) continue;
        svg.shapes += spreadMark(px(t.workMinMs), px(t.workMaxMs), py(p.y), colors.at(p.light->technique));
        for (double end : {t.workMinMs, t.workMaxMs}) labels.addSegment(px(end), py(p.y) - kSpreadCap, px(end), py(p.y) + kSpreadCap);
        labels.addSegment(px(t.workMinMs), py(p.y), px(t.workMaxMs), py(p.y));
    }
    for (const Point& p : points) {
        svg.shapes += pointMarker(px(p.x), py(p.y), colors.at(p.light->technique), p.light->paretoFront, pointTitle(p));
        labels.addPoint(px(p.x), py(p.y), kPointRadius);
    }
    for (const Point& p : points) {
        const BenchLight& l = *p.light;
        const std::string text = l.techniqueLabel.empty() ? l.technique : l.techniqueLabel;
        const PlacedLabel label = labels.place(px(p.x), py(p.y), kPointRadius, text);
        if (label.leader) {
            svg.shapes += fmt::format("<line x1=\"{:.1f}\" y1=\"{:.1f}\" x2=\"{:.1f}\" y2=\"{:.1f}\" stroke=\"#777\" "
                                      "stroke-width=\"0.8\"/>\n",
                                      label.leaderX0, label.leaderY0, label.leaderX1, label.leaderY1);
        }
        svg.text += svgText(label.x, label.y, kLabelText, label.anchor, text);
    }
}

} // namespace

std::string paretoSvg(const BenchRun& run)
{
    const std::vector<TradeoffPanel> panels = tradeoffPanels(run);
    std::map<std::string, std::string> colors;  // technique -> colour, in order of first appearance
    std::vector<std::string> techniques;
    bool anySpread = false;
    for (const BenchVariant& v : run.variants) {
        for (const BenchLight& l : v.lights) {
            anySpread = anySpread || hasSpread(l.timing);
            if (colors.count(l.technique)) continue;
            colors[l.technique] = kTechniqueColors[techniques.size() % std::size(kTechniqueColors)];
            techniques.push_back(l.technique);
        }
    }
    const size_t columns = std::clamp<size_t>(panels.size(), 1, 2);
    const size_t rows = std::max<size_t>(1, (panels.size() + columns - 1) / columns);
    const double width = double(columns) * kPanelWidth, height = kHeaderHeight + double(rows) * kPanelHeight;

    SvgLayers svg;
    svg.text += svgText(16, 24, kTitleText, "start", fmt::format("{}: error against time", run.config));
    svg.text += svgText(16, 44, kAxisText, "start",
                        fmt::format("{}; reference technique: {}; medians of {} frame(s)", run.device.value("name", ""),
                                    run.reference, run.frames));
    double legendX = 16;
    for (const std::string& technique : techniques) {
        svg.shapes += fmt::format("<circle cx=\"{:.1f}\" cy=\"64\" r=\"5\" fill=\"{}\"/>\n", legendX + 5, colors[technique]);
        svg.text += svgText(legendX + 14, 68, kAxisText, "start", technique);
        legendX += 30 + estimateTextWidth(technique, kAxisText.px);
    }
    const std::string frontText = "Pareto front (outlined points)";
    svg.shapes += fmt::format("<polyline points=\"{:.1f},64 {:.1f},64\" {}/>\n", legendX, legendX + 28, kFrontStroke);
    svg.text += svgText(legendX + 34, 68, kAxisText, "start", frontText);
    if (anySpread) {
        legendX += 50 + estimateTextWidth(frontText, kAxisText.px);
        svg.shapes += spreadMark(legendX, legendX + 24, 64, "#444444");
        svg.text += svgText(legendX + 30, 68, kAxisText, "start", "time's min–max over the frames");
    }
    for (size_t i = 0; i < panels.size(); ++i) {
        drawPanel(panels[i], run, double(i % columns) * kPanelWidth, kHeaderHeight + double(i / columns) * kPanelHeight, colors,
                  svg);
    }
    return fmt::format("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
                       "<svg xmlns=\"http://www.w3.org/2000/svg\" version=\"1.1\" width=\"{0}\" height=\"{1}\" "
                       "viewBox=\"0 0 {0} {1}\">\n"
                       "<rect width=\"100%\" height=\"100%\" fill=\"#fff\"/>\n{2}{3}</svg>\n",
                       width, height, svg.shapes, svg.text);
}

} // namespace penumbra::app
