#version 460
// tests/techniques/test_vssm_plugin.cpp: box queries of plugins/vssm's summed-area table
// (sat.glsl satBoxMoments), one per invocation, written in fp64.
layout(local_size_x = 64) in;

#define SAT_BINDING 0
#define SAT_QUALIFIER readonly
#define SAT_READ_ONLY
#include "sat.glsl"

layout(std430, binding = 1) readonly buffer Boxes {
    vec4 boxes[];  // xy: low corner, zw: high corner, in texels
};
layout(std430, binding = 2) writeonly buffer Results {
    dvec4 results[];  // mean, E(t^2), variance, area
};

layout(push_constant) uniform Push {
    ivec2 size;
    int count;
} pc;

void main()
{
    uint i = gl_GlobalInvocationID.x;
    if (i >= uint(pc.count)) return;
    results[i] = satBoxMoments(boxes[i].xy, boxes[i].zw, pc.size);
}
