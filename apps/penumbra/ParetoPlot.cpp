#include "ParetoPlot.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <tuple>

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

// Where a point's label goes: beside the point, on the first side where it stays inside
// the axes and clear of the labels and points placed before; where none is clear, the
// side with the fewest collisions. Text widths are estimated (10 px sans-serif: at most
// about 6 px per character), which is all the layout needs.
class LabelPlacer {
public:
    LabelPlacer(double left, double top, double right, double bottom) : left_(left), top_(top), right_(right), bottom_(bottom) {}

    void addPoint(double x, double y) { taken_.push_back({x - 5, y - 5, x + 5, y + 5}); }

    // The label's anchor position and text-anchor value.
    std::tuple<double, double, const char*> place(double x, double y, const std::string& text)
    {
        struct Side {
            double dx, dy;
            const char* anchor;
        };
        constexpr Side kSides[] = {{7, -6, "start"},    {7, 13, "start"},   {-7, -6, "end"},    {-7, 13, "end"},
                                   {0, -10, "middle"},  {0, 19, "middle"},  {7, -18, "start"},  {7, 25, "start"},
                                   {-7, -18, "end"},    {-7, 25, "end"}};
        const double width = 6.0 * double(text.size());
        size_t best = 0, fewest = SIZE_MAX;
        Box bestBox{};
        for (size_t i = 0; i < std::size(kSides); ++i) {
            const Side& side = kSides[i];
            const double ax = x + side.dx, ay = y + side.dy;
            const double x0 = side.anchor[0] == 's' ? ax : side.anchor[0] == 'e' ? ax - width : ax - 0.5 * width;
            const Box box{x0, ay - 9, x0 + width, ay + 2};
            const bool inside = box.x0 >= left_ && box.x1 <= right_ && box.y0 >= top_ && box.y1 <= bottom_;
            const size_t collisions = size_t(std::count_if(taken_.begin(), taken_.end(), [&](const Box& b) { return b.overlaps(box); })) +
                                      (inside ? 0 : 1000);
            if (collisions < fewest) {
                fewest = collisions;
                best = i;
                bestBox = box;
            }
            if (collisions == 0) break;
        }
        taken_.push_back(bestBox);
        return {x + kSides[best].dx, y + kSides[best].dy, kSides[best].anchor};
    }

private:
    struct Box {
        double x0, y0, x1, y1;
        bool overlaps(const Box& o) const { return x0 < o.x1 && o.x0 < x1 && y0 < o.y1 && o.y0 < y1; }
    };
    double left_, top_, right_, bottom_;
    std::vector<Box> taken_;
};

struct Point {
    double x = 0.0, y = 0.0;  // ms, RMSE
    const BenchLight* light = nullptr;
    const BenchVariant* variant = nullptr;
};

std::string drawPanel(const TradeoffPanel& panel, const BenchRun& run, double ox, double oy,
                      const std::map<std::string, std::string>& colors)
{
    std::vector<Point> points;
    for (const TradeoffPanel::Member& m : panel.members) {
        const BenchVariant& v = run.variants[m.variant];
        const BenchLight& l = v.lights[m.light];
        points.push_back({l.timing.workMs, l.visibility.all.rmse, &l, &v});
    }
    std::vector<double> times, errors;
    for (const Point& p : points) {
        times.push_back(p.x);
        errors.push_back(p.y);
    }
    const Axis x = timeAxis(times);
    const Axis y = linearAxis(errors.empty() ? 0.0 : *std::max_element(errors.begin(), errors.end()));
    const double left = ox + kLeft, right = ox + kPanelWidth - kRight, top = oy + kTop, bottom = oy + kPanelHeight - kBottom;
    const auto px = [&](double v) { return left + x.fraction(v) * (right - left); };
    const auto py = [&](double v) { return bottom - y.fraction(v) * (bottom - top); };

    std::string svg = fmt::format("<g>\n<text x=\"{:.1f}\" y=\"{:.1f}\" class=\"panel\">{}</text>\n", left, oy + 20,
                                  xmlText(panel.title));
    for (double t : x.ticks) {
        svg += fmt::format("<line x1=\"{0:.1f}\" y1=\"{1:.1f}\" x2=\"{0:.1f}\" y2=\"{2:.1f}\" class=\"grid\"/>"
                           "<text x=\"{0:.1f}\" y=\"{3:.1f}\" class=\"tick\" text-anchor=\"middle\">{4:g}</text>\n",
                           px(t), top, bottom, bottom + 16, t);
    }
    for (double t : y.ticks) {
        svg += fmt::format("<line x1=\"{0:.1f}\" y1=\"{2:.1f}\" x2=\"{1:.1f}\" y2=\"{2:.1f}\" class=\"grid\"/>"
                           "<text x=\"{3:.1f}\" y=\"{4:.1f}\" class=\"tick\" text-anchor=\"end\">{5:g}</text>\n",
                           left, right, py(t), left - 6, py(t) + 4, t);
    }
    svg += fmt::format("<rect x=\"{:.1f}\" y=\"{:.1f}\" width=\"{:.1f}\" height=\"{:.1f}\" class=\"frame\"/>\n", left, top,
                       right - left, bottom - top);
    svg += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" class=\"axis\" text-anchor=\"middle\">technique ms{}</text>\n",
                       0.5 * (left + right), oy + kPanelHeight - 14, x.log ? " (log scale)" : "");
    svg += fmt::format("<text transform=\"translate({:.1f} {:.1f}) rotate(-90)\" class=\"axis\" text-anchor=\"middle\">"
                       "RMSE against the reference</text>\n",
                       ox + 18, 0.5 * (top + bottom));

    // The front first, under the points: its points ordered by time (error falls along it).
    std::vector<const Point*> front;
    for (const Point& p : points)
        if (p.light->paretoFront) front.push_back(&p);
    std::sort(front.begin(), front.end(), [](const Point* a, const Point* b) { return a->x != b->x ? a->x < b->x : a->y < b->y; });
    if (front.size() > 1) {
        std::string coords;
        for (const Point* p : front) coords += fmt::format("{:.1f},{:.1f} ", px(p->x), py(p->y));
        svg += fmt::format("<polyline points=\"{}\" class=\"front\"/>\n", coords);
    }
    LabelPlacer labels(left, top, right, bottom);
    for (const Point& p : points) labels.addPoint(px(p.x), py(p.y));
    for (const Point& p : points) {
        const BenchLight& l = *p.light;
        const std::string label = l.techniqueLabel.empty() ? l.technique : l.techniqueLabel;
        const auto [labelX, labelY, anchor] = labels.place(px(p.x), py(p.y), label);
        svg += fmt::format("<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"4.5\" fill=\"{}\"{}><title>{}: {} {}; {:.4g} ms, RMSE "
                           "{:.4g}{}</title></circle>\n",
                           px(p.x), py(p.y), colors.at(l.technique), l.paretoFront ? " class=\"on-front\"" : "",
                           xmlText(p.variant->label.empty() ? "the config" : p.variant->label), xmlText(l.technique),
                           xmlText(l.params.dump()), p.x, p.y, l.paretoFront ? " (Pareto front)" : "");
        svg += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" class=\"label\" text-anchor=\"{}\">{}</text>\n", labelX, labelY,
                           anchor, xmlText(label));
    }
    return svg + "</g>\n";
}

} // namespace

std::string paretoSvg(const BenchRun& run)
{
    const std::vector<TradeoffPanel> panels = tradeoffPanels(run);
    std::map<std::string, std::string> colors;  // technique -> colour, in order of first appearance
    std::vector<std::string> techniques;
    for (const BenchVariant& v : run.variants) {
        for (const BenchLight& l : v.lights) {
            if (colors.count(l.technique)) continue;
            colors[l.technique] = kTechniqueColors[techniques.size() % std::size(kTechniqueColors)];
            techniques.push_back(l.technique);
        }
    }
    const size_t columns = std::clamp<size_t>(panels.size(), 1, 2);
    const size_t rows = std::max<size_t>(1, (panels.size() + columns - 1) / columns);
    const double width = double(columns) * kPanelWidth, height = kHeaderHeight + double(rows) * kPanelHeight;

    std::string svg = fmt::format(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
        "<svg xmlns=\"http://www.w3.org/2000/svg\" version=\"1.1\" width=\"{0}\" height=\"{1}\" viewBox=\"0 0 {0} {1}\">\n"
        "<style>\n"
        "text {{ font-family: sans-serif; fill: #222; }}\n"
        ".title {{ font-size: 15px; font-weight: bold; }} .panel {{ font-size: 13px; font-weight: bold; }}\n"
        ".axis {{ font-size: 12px; }} .tick {{ font-size: 10px; fill: #555; }} .label {{ font-size: 10px; }}\n"
        ".grid {{ stroke: #e4e4e4; stroke-width: 1; }} .frame {{ fill: none; stroke: #888; stroke-width: 1; }}\n"
        ".front {{ fill: none; stroke: #444; stroke-width: 1.5; stroke-dasharray: 5 3; }}\n"
        "circle {{ stroke: #fff; stroke-width: 1; }} circle.on-front {{ stroke: #000; stroke-width: 1.5; }}\n"
        "</style>\n"
        "<rect width=\"100%\" height=\"100%\" fill=\"#fff\"/>\n",
        width, height);
    svg += fmt::format("<text x=\"16\" y=\"24\" class=\"title\">{}: error against time</text>\n", xmlText(run.config));
    svg += fmt::format("<text x=\"16\" y=\"44\" class=\"axis\">{}; reference technique: {}; medians of {} frame(s)</text>\n",
                       xmlText(run.device.value("name", "")), xmlText(run.reference), run.frames);
    double legendX = 16;
    for (const std::string& technique : techniques) {
        svg += fmt::format("<circle cx=\"{:.1f}\" cy=\"64\" r=\"5\" fill=\"{}\"/><text x=\"{:.1f}\" y=\"68\" class=\"axis\">{}</text>\n",
                           legendX + 5, colors[technique], legendX + 14, xmlText(technique));
        legendX += 30 + 7.5 * double(technique.size());
    }
    svg += fmt::format("<polyline points=\"{0:.1f},64 {1:.1f},64\" class=\"front\"/><text x=\"{2:.1f}\" y=\"68\" "
                       "class=\"axis\">Pareto front (outlined points)</text>\n",
                       legendX, legendX + 28, legendX + 34);
    for (size_t i = 0; i < panels.size(); ++i) {
        svg += drawPanel(panels[i], run, double(i % columns) * kPanelWidth, kHeaderHeight + double(i / columns) * kPanelHeight,
                         colors);
    }
    return svg + "</svg>\n";
}

} // namespace penumbra::app
