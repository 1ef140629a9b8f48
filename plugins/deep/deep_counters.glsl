// What the deep shadow map's passes count in a frame (deep.cpp DeepCounters, std430): the
// figures `render --stats`, `bench` and the tests read. The including shader defines
// DEEP_COUNTERS_BINDING (default 5).
#ifndef PENUMBRA_DEEP_COUNTERS_GLSL
#define PENUMBRA_DEEP_COUNTERS_GLSL

#ifndef DEEP_COUNTERS_BINDING
#define DEEP_COUNTERS_BINDING 5
#endif

// Depth complexity histogram: bin 0 one fragment, bin b 2^b .. 2^(b+1) - 1, the last
// everything from 2^15 on. Empty texels are not counted.
#define DEEP_COMPLEXITY_BINS 16

layout(std430, binding = DEEP_COUNTERS_BINDING) buffer DeepCounters {
    uint fragments;     // fragments the fragment pass appended or would have (past the pool)
    uint kept;          // nodes left after the sort's truncation
    uint overSortCap;   // fragments beyond the DEEP_SORT_CAPACITY nearest of their texel: dropped
    uint longest;       // the longest list (fragments of one texel)
    uint complexity[DEEP_COMPLEXITY_BINS];
} counters;

#endif
