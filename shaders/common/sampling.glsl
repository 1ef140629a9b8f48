// Sampling patterns shared by shadow filters: the Poisson disk (poisson_disk.glsl, a
// filter takes its first N points) and a per-pixel rotation of it.
#ifndef PENUMBRA_SAMPLING_GLSL
#define PENUMBRA_SAMPLING_GLSL

#include "common/poisson_disk.glsl"

// Interleaved gradient noise (Jimenez 2014, "Next Generation Post Processing in Call of
// Duty: Advanced Warfare"): a per-pixel rotation of the disk turns the banding of one
// fixed pattern into fine noise.
float interleavedGradientNoise(vec2 pixel)
{
    return fract(52.9829189 * fract(dot(pixel, vec2(0.06711056, 0.00583715))));
}

// The rotation of the Poisson disk for `pixel`.
mat2 poissonRotation(ivec2 pixel)
{
    float angle = 6.28318531 * interleavedGradientNoise(vec2(pixel));
    float c = cos(angle), s = sin(angle);
    return mat2(c, s, -s, c);
}

#endif
