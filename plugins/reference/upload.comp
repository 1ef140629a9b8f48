#version 460
// The traced reference's last pass: V, one float per pixel from the host pass, into V_l
// (whose format is common/visibility.glsl's, which a buffer copy could not convert to).
#include "common/visibility.glsl"

layout(local_size_x = 64, local_size_y = 1) in;

layout(std430, binding = 0) readonly buffer Traced { float traced[]; };  // rows top first
layout(binding = 1, VISIBILITY_FORMAT) uniform writeonly image2D visibilityOut;

void main()
{
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(visibilityOut);
    if (any(greaterThanEqual(pixel, size))) return;
    imageStore(visibilityOut, pixel, vec4(sanitizeVisibility(traced[pixel.y * size.x + pixel.x])));
}
