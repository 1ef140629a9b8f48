#pragma once
// Wall-clock spans of the engine's CPU-side timings (culling steps, graph execution,
// frames).
#include <chrono>

namespace penumbra::core {

// Milliseconds since `start` on the steady clock.
inline double msSince(std::chrono::steady_clock::time_point start)
{
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

} // namespace penumbra::core
