#pragma once
// Where the labels of a scatter plot go (pareto.svg, ParetoPlot.h): each beside its point,
// inside the plot's frame, clear of every other label, every point and every line drawn
// (a Pareto front, spread marks, leader lines); the nearest clear spot that is no nearer
// to another point than to its own wins, and a label that had to move away from its point
// gets a leader line back to it. Only where no spot
// in the frame is clear does a label overlap something: never another label where any
// spot avoids that, and then as few points and lines as it can.
//
// The layout never measures a font: SVG leaves the font to the renderer. Text widths are
// estimated from DejaVu Sans's advance widths (the sans-serif of Debian's renderers, and
// wider than Helvetica or Arial), per class of character, so the boxes bound the text.
#include <string_view>
#include <vector>

namespace penumbra::app {

// An axis-aligned box in SVG pixels (y down).
struct PlotBox {
    double x0 = 0.0, y0 = 0.0, x1 = 0.0, y1 = 0.0;

    bool overlaps(const PlotBox& other) const;
    bool contains(const PlotBox& other) const;
    // Whether the segment from (ax, ay) to (bx, by) passes through the box.
    bool crosses(double ax, double ay, double bx, double by) const;
};

// The estimated advance width of `text` (UTF-8) at `fontPx` pixels.
double estimateTextWidth(std::string_view text, double fontPx);

struct PlacedLabel {
    double x = 0.0, y = 0.0;        // the text's anchor point: on its baseline
    const char* anchor = "start";   // the SVG text-anchor: "start" or "end"
    PlotBox box;                    // the text's estimated extent
    bool clear = true;              // false: no clear spot was left (see above)
    // Set when the label stands away from its point: the line to draw from the point's
    // edge (leaderX0, leaderY0) to the label box's nearest edge (leaderX1, leaderY1).
    bool leader = false;
    double leaderX0 = 0.0, leaderY0 = 0.0, leaderX1 = 0.0, leaderY1 = 0.0;
};

class LabelPlacer {
public:
    // Labels stay inside `frame`; `fontPx` is the labels' font size.
    LabelPlacer(const PlotBox& frame, double fontPx);

    // What labels must not cover: a point drawn as a disc of `radius`, a line.
    void addPoint(double x, double y, double radius);
    void addSegment(double ax, double ay, double bx, double by);

    // Places the label of the point at (x, y) (of `radius`), which then, with its leader
    // line, is an obstacle for the labels placed after it.
    PlacedLabel place(double x, double y, double radius, std::string_view text);

private:
    struct Segment {
        double ax, ay, bx, by;
    };
    size_t textOverlaps(const PlotBox& box) const;
    size_t shapeOverlaps(const PlotBox& box) const;
    size_t leaderCrossings(const PlacedLabel& label) const;

    PlotBox frame_;
    double fontPx_;
    std::vector<PlotBox> points_;  // each point's disc, as a box
    std::vector<PlotBox> labels_;  // the labels placed so far
    std::vector<Segment> segments_;
};

} // namespace penumbra::app
