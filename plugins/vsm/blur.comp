#version 460
// One axis of the VSM family's separable blur (Donnelly & Lauritzen 2006: the stored
// values are linear in the occluders, so a blurred map is a filtered one; ESM's depths
// are blurred in log space, moments.glsl FilterSum): each texel becomes the weighted
// mean of the 2 radius + 1 texels around it along `axis`, Gaussian (sigma = radius / 2,
// cut at 2 sigma) or box weights. Taps stay in their cube face's atlas cell: the next
// cell is another face.
//
// Defines (vsm.cpp): MOMENT_FORMAT the storage format, BLUR_KERNEL 0 gaussian, 1 box,
// VSM_VARIANT and MOMENT_CHANNELS (moments.glsl).
#include "moments.glsl"

#ifndef MOMENT_FORMAT
#define MOMENT_FORMAT rg32f
#endif
#ifndef BLUR_KERNEL
#define BLUR_KERNEL 0
#endif

layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 0, MOMENT_FORMAT) uniform readonly image2D momentsIn;
layout(binding = 1, MOMENT_FORMAT) uniform writeonly image2D momentsOut;

layout(push_constant) uniform Push {
    ivec2 axis;      // (1, 0) or (0, 1)
    int radius;      // texels, >= 1
    int faceTexels;  // the size of one atlas cell
    float exponent;  // ESM's c (FilterSum)
} pc;

float weight(int offset, float sigma)
{
#if BLUR_KERNEL == 0
    return exp(-float(offset * offset) / (2.0 * sigma * sigma));
#else
    return 1.0;
#endif
}

void main()
{
    // The push constants are loaded before the first branch, and the texels past the
    // image's edge compute a clamped texel and store nothing: on llvmpipe a uniform value
    // is loaded once per SIMD group only outside divergent control flow
    // (docs/performance.md, "Uniform loads").
    ivec2 axis = pc.axis;
    int radius = pc.radius, faceTexels = pc.faceTexels;
    float exponent = pc.exponent;
    float sigma = 0.5 * float(max(radius, 1));  // >= 0.5: no division by zero
    ivec2 size = imageSize(momentsOut);
    ivec2 texel = ivec2(gl_GlobalInvocationID.xy);
    bool inImage = all(lessThan(texel, size));
    texel = min(texel, size - 1);
    ivec2 cellStart = (texel / faceTexels) * faceTexels;
    ivec2 cellEnd = min(cellStart + faceTexels, size) - 1;
    FilterSum f = emptyFilterSum();
    for (int i = -radius; i <= radius; ++i)
        addToFilter(f, imageLoad(momentsIn, clamp(texel + i * axis, cellStart, cellEnd)), weight(i, sigma), exponent);
    vec4 result = filterResult(f, exponent);
    if (inImage) imageStore(momentsOut, texel, result);
}
