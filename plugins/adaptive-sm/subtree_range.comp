#version 460
// The depth range of every resident node's subtree (AsmRanges.zw): its own tile's range
// with its children's subtree ranges, level by level from the deepest up, in one
// workgroup (barriers order the levels). Evicted children are gone from the table, so a
// range never keeps a removed tile's depths.
#ifndef ASM_TILE
#define ASM_TILE 128
#define ASM_ATLAS_COLUMNS 16
#define ASM_MAX_LEVEL 10
#endif
#define ASM_LEVEL_SLOTS 17  // tile_tree.h kMaxLevels + 1

layout(local_size_x = 64) in;

#define ASM_NODES_BINDING 1
#define ASM_RANGES_BINDING 2
#define ASM_RANGES_WRITABLE
#include "asm_tree.glsl"

// TileTree::bottomUpOrder: resident slots, deepest level first, and where each level starts.
layout(std430, binding = 3) readonly buffer AsmOrder {
    uint levelStart[ASM_LEVEL_SLOTS];
    uint slots[];
} order;

void main()
{
    for (int l = 0; l + 1 < ASM_LEVEL_SLOTS; ++l) {
        for (uint k = order.levelStart[l] + gl_LocalInvocationIndex; k < order.levelStart[l + 1]; k += 64u) {
            uint slot = order.slots[k];
            vec2 range = asmRanges.ranges[slot].xy;
            ivec4 children = asmTree.nodes[slot].children;
            for (int q = 0; q < 4; ++q) {
                if (children[q] < 0) continue;
                vec4 child = asmRanges.ranges[children[q]];
                range = vec2(min(range.x, child.z), max(range.y, child.w));
            }
            asmRanges.ranges[slot].zw = range;
        }
        memoryBarrierBuffer();
        barrier();
    }
}
