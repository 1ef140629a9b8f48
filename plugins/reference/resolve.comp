#version 460
// The rasterised reference's last pass (accumulate.comp made the sums): V = the weighted
// mean of the samples' compares. A pixel whose weights sum to zero (no geometry, or a
// receiver inside a sphere light, where nothing lies between) is lit.
#include "common/visibility.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 0, rg32f) uniform readonly image2D sums;
layout(binding = 1, VISIBILITY_FORMAT) uniform writeonly image2D visibilityOut;

void main()
{
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(pixel, imageSize(visibilityOut)))) return;
    vec2 sum = imageLoad(sums, pixel).xy;
    float v = sum.y > 0.0 ? sum.x / sum.y : VISIBILITY_NO_GEOMETRY;
    imageStore(visibilityOut, pixel, vec4(sanitizeVisibility(v)));
}
