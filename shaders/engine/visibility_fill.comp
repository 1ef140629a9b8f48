#version 460
// V = 1 over a light's visibility image outside the rectangle its visibility pass ran
// over (plugin::addVisibilityStepPass): the pixels the light cannot light, where shading
// never reads V, hold what a pixel the light leaves alone holds for a reader of the image
// (compare, a debug image, the EXR).
#include "common/visibility.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 0, VISIBILITY_FORMAT) uniform writeonly image2D visibilityOut;

layout(push_constant) uniform Push {
    ivec4 inside;  // x0, y0, x1, y1: the pixels the pass ran over (x1, y1 past the last)
} pc;

void main()
{
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(pixel, imageSize(visibilityOut)))) return;
    if (all(greaterThanEqual(pixel, pc.inside.xy)) && all(lessThan(pixel, pc.inside.zw))) return;
    imageStore(visibilityOut, pixel, vec4(1.0));
}
