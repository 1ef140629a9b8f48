#version 460
#include "common/visibility.glsl"
layout(local_size_x = 1) in;
layout(binding = 0, VISIBILITY_FORMAT) uniform writeonly image2D img;
void main() { imageStore(img, ivec2(0), vec4(sanitizeVisibility(2.0))); }
