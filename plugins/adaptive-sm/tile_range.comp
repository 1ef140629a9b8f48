#version 460
// The depth range of each tile drawn this frame (one workgroup per tile): its own min and
// max depth into AsmRanges.xy, for subtree_range.comp to combine.
#ifndef ASM_TILE
#define ASM_TILE 128
#define ASM_ATLAS_COLUMNS 16
#define ASM_MAX_LEVEL 10
#endif

layout(local_size_x = 64) in;

layout(binding = 0) uniform sampler2D atlas;

#define ASM_NODES_BINDING 1
#define ASM_RANGES_BINDING 2
#define ASM_RANGES_WRITABLE
#include "asm_tree.glsl"

// The slots drawn this frame.
layout(std430, binding = 3) readonly buffer AsmTileList {
    uint slots[];
} tileList;

shared vec2 partial[64];

void main()
{
    uint slot = tileList.slots[gl_WorkGroupID.x];
    ivec2 origin = ivec2(slot % uint(ASM_ATLAS_COLUMNS), slot / uint(ASM_ATLAS_COLUMNS)) * ASM_TILE;
    vec2 range = vec2(1e30, -1e30);
    for (uint i = gl_LocalInvocationIndex; i < uint(ASM_TILE * ASM_TILE); i += 64u) {
        float d = texelFetch(atlas, origin + ivec2(i % uint(ASM_TILE), i / uint(ASM_TILE)), 0).r;
        range = vec2(min(range.x, d), max(range.y, d));
    }
    partial[gl_LocalInvocationIndex] = range;
    barrier();
    for (uint half_ = 32u; half_ > 0u; half_ >>= 1) {
        if (gl_LocalInvocationIndex < half_) {
            vec2 other = partial[gl_LocalInvocationIndex + half_];
            partial[gl_LocalInvocationIndex] = vec2(min(partial[gl_LocalInvocationIndex].x, other.x),
                                                    max(partial[gl_LocalInvocationIndex].y, other.y));
        }
        barrier();
    }
    if (gl_LocalInvocationIndex == 0u) asmRanges.ranges[slot].xy = partial[0];
}
