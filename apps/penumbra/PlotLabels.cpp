#include "PlotLabels.h"

#include <algorithm>
#include <cmath>
#include <tuple>

namespace penumbra::app {

bool PlotBox::overlaps(const PlotBox& o) const { return x0 < o.x1 && o.x0 < x1 && y0 < o.y1 && o.y0 < y1; }

bool PlotBox::contains(const PlotBox& o) const { return o.x0 >= x0 && o.x1 <= x1 && o.y0 >= y0 && o.y1 <= y1; }

bool PlotBox::crosses(double ax, double ay, double bx, double by) const
{
    // Liang–Barsky: clip the segment's parameter range [0, 1] against the four edges.
    const double dx = bx - ax, dy = by - ay;
    const double p[4] = {-dx, dx, -dy, dy};
    const double q[4] = {ax - x0, x1 - ax, ay - y0, y1 - ay};
    double t0 = 0.0, t1 = 1.0;
    for (int i = 0; i < 4; ++i) {
        if (p[i] == 0.0) {
            if (q[i] < 0.0) return false;  // parallel to this edge and outside it
            continue;
        }
        const double t = q[i] / p[i];
        if (p[i] < 0.0)
            t0 = std::max(t0, t);
        else
            t1 = std::min(t1, t);
        if (t0 > t1) return false;
    }
    return true;
}

double estimateTextWidth(std::string_view text, double fontPx)
{
    // DejaVu Sans advance widths in em, rounded up per class: narrow punctuation and
    // letters (i: 0.28, f: 0.35, space: 0.32), the widest letters (m: 0.97, W: 0.99),
    // capitals and wide symbols (up to 0.84), everything else (digits 0.64, a: 0.61).
    constexpr std::string_view kNarrow = " .,:;'!|()[]{}-fijlrtI";
    constexpr std::string_view kWidest = "mwMW%@";
    constexpr std::string_view kWide = "=+<>_~#&*?\"";
    double em = 0.0;
    for (char c : text) {
        const auto byte = static_cast<unsigned char>(c);
        if ((byte & 0xC0) == 0x80) continue;  // a UTF-8 continuation byte: part of the character before
        if (kNarrow.find(c) != std::string_view::npos)
            em += 0.40;
        else if (kWidest.find(c) != std::string_view::npos)
            em += 1.0;
        else if (kWide.find(c) != std::string_view::npos || (c >= 'A' && c <= 'Z'))
            em += 0.84;
        else
            em += 0.65;
    }
    return em * fontPx;
}

LabelPlacer::LabelPlacer(const PlotBox& frame, double fontPx) : frame_(frame), fontPx_(fontPx) {}

void LabelPlacer::addPoint(double x, double y, double radius)
{
    points_.push_back({x - radius - 1.0, y - radius - 1.0, x + radius + 1.0, y + radius + 1.0});
}

void LabelPlacer::addSegment(double ax, double ay, double bx, double by) { segments_.push_back({ax, ay, bx, by}); }

size_t LabelPlacer::textOverlaps(const PlotBox& box) const
{
    return size_t(std::count_if(labels_.begin(), labels_.end(), [&](const PlotBox& b) { return b.overlaps(box); }));
}

size_t LabelPlacer::shapeOverlaps(const PlotBox& box) const
{
    size_t n = size_t(std::count_if(points_.begin(), points_.end(), [&](const PlotBox& b) { return b.overlaps(box); }));
    for (const Segment& s : segments_) n += box.crosses(s.ax, s.ay, s.bx, s.by) ? 1 : 0;
    return n;
}

size_t LabelPlacer::leaderCrossings(const PlacedLabel& label) const
{
    // The boxes it starts in are its own point's (and those of points drawn at the same place).
    const PlotBox start{label.leaderX0, label.leaderY0, label.leaderX0, label.leaderY0};
    size_t n = 0;
    for (const std::vector<PlotBox>* boxes : {&points_, &labels_}) {
        for (const PlotBox& b : *boxes) {
            if (!b.contains(start)) n += b.crosses(label.leaderX0, label.leaderY0, label.leaderX1, label.leaderY1) ? 1 : 0;
        }
    }
    return n;
}

PlacedLabel LabelPlacer::place(double x, double y, double radius, std::string_view text)
{
    const double width = estimateTextWidth(text, fontPx_);
    // The text's extent about its baseline (DejaVu Sans: ascent 0.76 em, descent 0.24 em),
    // with a pixel of margin, and the gap between a point's disc and its label.
    const double above = 0.8 * fontPx_ + 1.0, below = 0.25 * fontPx_ + 1.0;
    const double gap = radius + 3.0;
    const double leaderBeyond = gap + fontPx_;  // a label farther from its point than this gets a leader
    // The baseline that centres the text on the point, then every half line up and down
    // through the frame; at each, the label starting right of the point or ending left of
    // it, each also shifted in steps of two ems: out as far as the frame reaches, and in
    // over the point's column (a label above or below it).
    const double centredBaseline = y + 0.5 * (above - below);
    const double step = 0.5 * fontPx_;
    const int stepsUp = int(std::ceil((centredBaseline - frame_.y0) / step));
    const int stepsDown = int(std::ceil((frame_.y1 - centredBaseline) / step));
    const double shiftStep = 2.0 * fontPx_;
    const int shiftsOut = 1 + int(std::ceil(std::max(frame_.x1 - x, x - frame_.x0) / shiftStep));
    const int shiftsIn = int(std::ceil((width + gap) / shiftStep));

    struct Candidate {
        PlacedLabel label;
        size_t textOverlaps;  // other labels it covers: text on text, avoided first
        size_t shapeOverlaps; // points and lines it covers or its leader crosses
        bool nearerAnother;   // nearer to another point than to its own: it would read as that one's
        double distance;      // from the point to the text's anchored end, for the order of preference
        int rank;             // |baseline steps| then side: which of two equally near spots reads best
    };
    std::vector<Candidate> candidates;
    const auto consider = [&](double ax, double ay, const char* anchor, int rank) {
        const double x0 = anchor[0] == 's' ? ax : ax - width;
        PlacedLabel label;
        label.x = ax;
        label.y = ay;
        label.anchor = anchor;
        label.box = {x0, ay - above, x0 + width, ay + below};
        if (!frame_.contains(label.box)) return;
        const double nearX = std::clamp(x, label.box.x0, label.box.x1), nearY = std::clamp(y, label.box.y0, label.box.y1);
        const double distance = std::hypot(nearX - x, nearY - y);
        if (distance < radius + 1.0) return;  // it would cover its own point
        if (distance > leaderBeyond) {
            label.leader = true;
            label.leaderX0 = x + (nearX - x) / distance * (radius + 1.0);
            label.leaderY0 = y + (nearY - y) / distance * (radius + 1.0);
            label.leaderX1 = nearX;
            label.leaderY1 = nearY;
        }
        const size_t shapes = shapeOverlaps(label.box) + (label.leader ? leaderCrossings(label) : 0);
        // Right above or below the point comes last: such a label closes the way out for
        // the leaders of labels stacked beside the point after it.
        const double abovePenalty = nearX == x ? 3.0 * fontPx_ : 0.0;
        // A label reads as the point nearest to where its text begins (or, anchored at its
        // end, ends), not to its box: a wide label above a point can start beside another.
        const double textX = ax, textY = ay - 0.5 * (above - below);
        const double own = std::hypot(textX - x, textY - y);
        const bool nearerAnother = std::any_of(points_.begin(), points_.end(), [&](const PlotBox& p) {
            return std::hypot(textX - 0.5 * (p.x0 + p.x1), textY - 0.5 * (p.y0 + p.y1)) < own - 1.0;
        });
        candidates.push_back({label, textOverlaps(label.box), shapes, nearerAnother, own + abovePenalty, rank});
    };
    for (int k = -stepsUp; k <= stepsDown; ++k) {
        const double baseline = centredBaseline + k * step;
        const int rank = 2 * std::abs(k);
        for (int shift = -shiftsIn; shift < shiftsOut; ++shift) {
            consider(x + gap + shiftStep * shift, baseline, "start", rank);
            consider(x - gap - shiftStep * shift, baseline, "end", rank + 1);
        }
    }
    // Nothing fits in the frame (a label wider than it): at the point's right, as it is.
    if (candidates.empty()) {
        PlacedLabel label;
        label.x = x + gap;
        label.y = centredBaseline;
        label.box = {label.x, centredBaseline - above, label.x + width, centredBaseline + below};
        label.clear = false;
        labels_.push_back(label.box);
        return label;
    }
    const auto best = std::min_element(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
        return std::tie(a.textOverlaps, a.shapeOverlaps, a.nearerAnother, a.distance, a.rank) <
               std::tie(b.textOverlaps, b.shapeOverlaps, b.nearerAnother, b.distance, b.rank);
    });
    PlacedLabel label = best->label;
    label.clear = best->textOverlaps == 0 && best->shapeOverlaps == 0;
    labels_.push_back(label.box);
    if (label.leader) addSegment(label.leaderX0, label.leaderY0, label.leaderX1, label.leaderY1);
    return label;
}

} // namespace penumbra::app
