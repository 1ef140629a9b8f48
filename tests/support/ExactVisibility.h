#pragma once
// Closed forms of exact visibility that several technique tests compare with.
#include <algorithm>
#include <cmath>
#include <numbers>

namespace penumbra::test {

// The area fraction of a unit disk beyond a chord at signed distance h from its centre
// (h = 1: the whole disk, 0: half, -1: none): what a disk light of radius r holds beyond
// a plane that its centre lies h r before.
inline double diskBeyondChord(double h)
{
    h = std::clamp(h, -1.0, 1.0);
    return (std::acos(-h) + h * std::sqrt(1.0 - h * h)) / std::numbers::pi;
}

} // namespace penumbra::test
