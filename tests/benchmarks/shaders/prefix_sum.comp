#version 460
// The floor of VSSM's summed-area table (plugins/vssm/sat.comp), for
// tests/benchmarks/bench_vssm_tables.cpp: a plain prefix sum of the moments (t, t^2) of a
// float map of the same size, with the same schedule (one invocation sweeps a row, then
// one a column). Two entry formats:
// - default: RG32F sums, the plain table the paper rejects at 1024^2 and above (fp32
//   sums lose the variance; plugins/vssm/sat.glsl);
// - FIXED_POINT: the plugin's own 64-bit fixed-point entries (sat.glsl's satFixedMoments
//   and satStore), so that what is left between this and the plugin's pass is the map's
//   depth linearisation (shadowLinearDepth, per cube face).
layout(local_size_x = 64) in;

layout(binding = 0) uniform sampler2D depthMap;

#ifdef FIXED_POINT
#define SAT_BINDING 1
#define SAT_QUALIFIER
#include "sat.glsl"  // plugins/vssm, on the search path
#define Sum u64vec2
Sum moments(float t) { return satFixedMoments(t); }
Sum loadEntry(ivec2 texel) { return satLoad(texel); }
void storeEntry(ivec2 texel, Sum sums) { satStore(texel, sums); }
#else
layout(binding = 1, rg32f) uniform image2D table;
#define Sum vec2
Sum moments(float t) { return vec2(t, t * t); }
Sum loadEntry(ivec2 texel) { return imageLoad(table, texel).xy; }
void storeEntry(ivec2 texel, Sum sums) { imageStore(table, texel, vec4(sums, 0.0, 0.0)); }
#endif

layout(push_constant) uniform Push {
    ivec2 size;    // the map, in texels
    int vertical;  // 0: rows (from the map), 1: columns (in place)
} pc;

void main()
{
    ivec2 size = pc.size;
    bool vertical = pc.vertical != 0;
    int line = int(gl_GlobalInvocationID.x);
    Sum run = Sum(0);
    if (!vertical) {
        if (line >= size.y) return;
        for (int x = 0; x < size.x; ++x) {
            ivec2 texel = ivec2(x, line);
            run += moments(texelFetch(depthMap, texel, 0).r);
            storeEntry(texel, run);
        }
    } else {
        if (line >= size.x) return;
        for (int y = 0; y < size.y; ++y) {
            ivec2 texel = ivec2(line, y);
            run += loadEntry(texel);
            storeEntry(texel, run);
        }
    }
}
