#version 460
// Reads a depth-comparison sampler at given points: each probe holds (u, v, reference)
// in xyz and receives the sampler's result in w. The hard plugin's bilinear filter
// relies on what this measures (tests/techniques/test_hard_shaders.cpp).
layout(local_size_x = 1) in;

layout(binding = 0) uniform sampler2DShadow depthMap;
layout(std430, binding = 1) buffer Probes { vec4 probes[]; };

void main()
{
    uint i = gl_GlobalInvocationID.x;
    probes[i].w = texture(depthMap, probes[i].xyz);
}
