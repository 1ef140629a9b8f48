#pragma once
// Process-wide counters of the reference plugin, for tests and tools that need to know
// whether a frame was traced or came from the cache without timing it. The plugin
// exports PENUMBRA_REFERENCE_STATS_SYMBOL; look it up with dlsym in the loaded
// penumbra-reference.so.
#include <cstdint>

#define PENUMBRA_REFERENCE_STATS_SYMBOL "penumbra_reference_stats"

extern "C" {

struct PenumbraReferenceStats {
    uint64_t framesTraced;   // frames whose V was computed by tracing rays
    uint64_t raysTraced;     // shadow rays of those frames
    uint64_t cacheHits;      // frames whose V came from the cache (the last frame's, or a file)
    uint64_t cacheRejected;  // cache files found but not used: damaged, truncated, another size
    uint64_t cacheWrites;    // cache files written
};

using PenumbraReferenceStatsFn = PenumbraReferenceStats (*)();

} // extern "C"
