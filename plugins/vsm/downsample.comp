#version 460
// One level of the VSM family's mip chain: each texel is the mean of the 2 x 2 texels of
// the level above it (ESM's in log space, moments.glsl FilterSum). Cube faces are powers
// of two wide (vsm.cpp checks), so the four always lie in the same face's atlas cell.
#include "moments.glsl"

#ifndef MOMENT_FORMAT
#define MOMENT_FORMAT rg32f
#endif

layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 0, MOMENT_FORMAT) uniform readonly image2D finer;
layout(binding = 1, MOMENT_FORMAT) uniform writeonly image2D coarser;

layout(push_constant) uniform Push {
    float exponent;  // ESM's c (FilterSum)
} pc;

void main()
{
    // Loaded before the first branch (blur.comp says why).
    float exponent = pc.exponent;
    ivec2 texel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(texel, imageSize(coarser)))) return;
    FilterSum f = emptyFilterSum();
    for (int y = 0; y < 2; ++y)
        for (int x = 0; x < 2; ++x) addToFilter(f, imageLoad(finer, 2 * texel + ivec2(x, y)), 0.25, exponent);
    imageStore(coarser, texel, filterResult(f, exponent));
}
