#version 460
// plugin::GBufferExport: the G-buffer's world positions and normals as plain floats, for
// work on the CPU (the reference's ray tracer, tests). Computed by common/gbuffer.glsl's
// own readers, so the CPU sees exactly what the techniques' shaders see.
#define GBUFFER_BINDING 0
#include "common/gbuffer.glsl"

layout(local_size_x = 64, local_size_y = 1) in;

layout(std430, binding = 3) writeonly buffer Positions { vec4 positions[]; };  // w = 1 surface, 0 none
// xyz the unit normal, w the position's error bound (gbufferPositionError, world units:
// the reference starts its shadow rays a few of them off the surface); 0 where no surface.
layout(std430, binding = 4) writeonly buffer Normals { vec4 normals[]; };

void main()
{
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = gbufferSize();
    if (any(greaterThanEqual(pixel, size))) return;
    uint i = uint(pixel.y) * uint(size.x) + uint(pixel.x);
    vec4 p = gbufferPosition(pixel);
    positions[i] = p;
    vec4 surface = vec4(gbufferNormal(pixel), gbufferPositionError(p.xyz));
    normals[i] = p.w != 0.0 ? surface : vec4(0.0);
}
