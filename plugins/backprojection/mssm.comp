#version 460
// One level of the multi-scale shadow map (mssm.glsl): level 0 from the depth map (each
// dual cell's 2 x 2 samples), level l >= 1 from four nodes of level l - 1 (Yang et al.
// 2009 §4.2: the first level over the dual grid, so that nodes match contour blocks).
// A second depth layer's MSSM is built the same way, in the array layers after the first's.
layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 0) uniform sampler2D shadowDepth;

#define MSSM_BINDING 1
#define MSSM_QUALIFIER
#define MSSM_WRITES
#include "mssm.glsl"

layout(push_constant) uniform Push {
    ivec2 atlasSize;
    int faceTexels;
    int level;
    int base;  // the depth layer's first array layer (mssm.glsl): a second depth layer's follow the first's
} pc;

// Straight-line (docs/performance.md, "Uniform loads"): invocations past the atlas
// compute a clamped cell and store nothing. MSSM_LEVEL0 selects level 0's pipeline, so
// that neither runs the other's loads (a branch on the level ran both: llvmpipe masks
// lanes, it does not skip a side).
#ifndef MSSM_LEVEL0
#define MSSM_LEVEL0 0
#endif
void main()
{
    ivec2 atlasSize = pc.atlasSize;
    int faceTexels = pc.faceTexels;
    ivec2 cell = ivec2(gl_GlobalInvocationID.xy);
    bool inAtlas = all(lessThan(cell, atlasSize));
    cell = min(cell, atlasSize - 1);
    ivec2 last = mssmFaceLast(cell, faceTexels);
#if MSSM_LEVEL0
    ivec2 b = min(cell + 1, last);
    float d00 = texelFetch(shadowDepth, cell, 0).r, d10 = texelFetch(shadowDepth, ivec2(b.x, cell.y), 0).r;
    float d01 = texelFetch(shadowDepth, ivec2(cell.x, b.y), 0).r, d11 = texelFetch(shadowDepth, b, 0).r;
    vec2 range = vec2(min(min(d00, d10), min(d01, d11)), max(max(d00, d10), max(d01, d11)));
    if (inAtlas) imageStore(mssmImage, mssmTexel(pc.base, 0, cell), vec4(range, 0.0, 0.0));
#else
    int level = pc.level;
    ivec2 b = min(cell + (1 << (level - 1)), last);
    vec2 v00 = mssmNode(pc.base, level - 1, cell);
    vec2 v10 = mssmNode(pc.base, level - 1, ivec2(b.x, cell.y));
    vec2 v01 = mssmNode(pc.base, level - 1, ivec2(cell.x, b.y));
    vec2 v11 = mssmNode(pc.base, level - 1, b);
    vec2 range = vec2(min(min(v00.x, v10.x), min(v01.x, v11.x)), max(max(v00.y, v10.y), max(v01.y, v11.y)));
    if (inAtlas) imageStore(mssmImage, mssmTexel(pc.base, level, cell), vec4(range, 0.0, 0.0));
#endif
}
