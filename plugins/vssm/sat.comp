#version 460
// VSSM step L3 (paper Algorithm 1): the summed-area table of the map's moments
// (sat.glsl), as two scans: along every row (the fixed-point moments of each texel's
// depth, prefix-summed), then along every column of the result. One invocation sweeps
// one line serially: linear in the map's size, and what a CPU rasteriser runs fastest
// (PLATFORM.md: serial sweeps beat shared-memory scans); adjacent invocations touch
// adjacent entries in the column scan.
layout(local_size_x = 64) in;

layout(binding = 0) uniform sampler2D shadowDepth;

#define SAT_BINDING 1
#define SAT_QUALIFIER
#include "sat.glsl"

#define SHADOW_MAP_BINDING 2
#include "common/shadow_map.glsl"

layout(push_constant) uniform Push {
    ivec2 size;    // the atlas, in texels
    int vertical;  // 0: rows (from the depth map), 1: columns (in place)
} pc;

void main()
{
    // The push constants and a one-face map's depth range are loaded before the first
    // branch: on llvmpipe a uniform value is loaded once per SIMD group only outside
    // divergent control flow (docs/performance.md, "Uniform loads").
    ivec2 size = pc.size;
    bool vertical = pc.vertical != 0;
    vec4 range0 = shadowMapData.faces[0].depthRange;
    int line = int(gl_GlobalInvocationID.x);
    u64vec2 run = u64vec2(uint64_t(0));
    if (!vertical) {
        if (line >= size.y) return;
        for (int x = 0; x < size.x; ++x) {
            ivec2 texel = ivec2(x, line);
            float depth = texelFetch(shadowDepth, texel, 0).r;
            float t = shadowFaceCount() == 1u ? shadowLinearDepthInRange(range0, depth)
                                              : shadowLinearDepth(shadowFaceOfTexel(texel), depth);
            run += satFixedMoments(t);
            satStore(texel, run);
        }
    } else {
        if (line >= size.x) return;
        for (int y = 0; y < size.y; ++y) {
            ivec2 texel = ivec2(line, y);
            run += satLoad(texel);
            satStore(texel, run);
        }
    }
}
