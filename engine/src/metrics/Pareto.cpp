#include "penumbra/metrics/Pareto.h"

#include <algorithm>
#include <cmath>
#include <optional>

namespace penumbra::metrics {

std::vector<size_t> paretoFront(std::span<const TradeoffPoint> points)
{
    std::vector<size_t> order;
    for (size_t i = 0; i < points.size(); ++i) {
        if (!std::isnan(points[i].timeMs) && !std::isnan(points[i].error)) order.push_back(i);
    }
    std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
        const TradeoffPoint &p = points[a], &q = points[b];
        if (p.timeMs != q.timeMs) return p.timeMs < q.timeMs;
        if (p.error != q.error) return p.error < q.error;
        return a < b;
    });
    // One pass over groups of equal time. A point is dominated by a faster point with no
    // larger error (`fasterBest`: the least error of all faster points), or by a point of
    // the same time with a smaller error (the group's first, after sorting).
    std::vector<size_t> front;
    std::optional<double> fasterBest;
    for (size_t begin = 0; begin < order.size();) {
        size_t end = begin;
        while (end < order.size() && points[order[end]].timeMs == points[order[begin]].timeMs) ++end;
        const double groupBest = points[order[begin]].error;
        for (size_t k = begin; k < end; ++k) {
            const double error = points[order[k]].error;
            const bool dominated = (fasterBest && *fasterBest <= error) || error > groupBest;
            if (!dominated) front.push_back(order[k]);
        }
        fasterBest = fasterBest ? std::min(*fasterBest, groupBest) : groupBest;
        begin = end;
    }
    return front;
}

} // namespace penumbra::metrics
