#pragma once
// The speed–accuracy trade-off of a set of measured configurations: which of them are
// worth having. A point (time, error) is dominated when another point is no slower and
// no less accurate, and strictly better in one of the two; the Pareto front is the set
// of points that no other point dominates. For any time budget, the most accurate choice
// within it lies on the front.
#include <cstddef>
#include <span>
#include <vector>

namespace penumbra::metrics {

struct TradeoffPoint {
    double timeMs = 0.0;  // lower is better
    double error = 0.0;   // lower is better (RMSE against the reference)
};

// Indices of the points on the Pareto front, ordered by time (ties by error, then
// index); error never rises along it. Equal points are all on the front, since neither
// dominates the other. A point with a NaN coordinate takes no part: it is neither on the
// front nor dominates anything.
std::vector<size_t> paretoFront(std::span<const TradeoffPoint> points);

} // namespace penumbra::metrics
