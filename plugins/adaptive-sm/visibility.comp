#version 460
// The adaptive shadow map's query (thesis ch. 2, "Process flow": Query): each G-buffer
// position is projected into the light view, the quadtree is walked from the root to the
// finest resident node over it and the receiver's depth compared with that node's tile
// (reversed-Z: lit where the receiver's depth is >= the stored caster depth; constant and
// slope-scaled bias are the rasterizer's, per tile, so they follow each tile's texel
// size). V_l is the fraction of passing compares (shaders/common/visibility.glsl).
//
//   PCF_KERNEL           1: one compare; k: a k x k box at the finest node's texel
//                        spacing. A tap inside that node's tile reads it; a tap that
//                        leaves the tile walks the tree again from its own point, down to
//                        the finest node there that is no finer than the centre's (the
//                        neighbour, or a coarser one): no seam at tile borders. A finer
//                        neighbour is not read: its tile's bias covers its own texel, not
//                        the centre's tap spacing, and a sloped receiver compared one
//                        coarse texel away fails against it (a dark line along the border
//                        of a refined region).
//   ASM_DEPTH_CULLING    1: the walk stops at the first node whose subtree depth range
//                        decides the compare (receiver >= its max: lit; < its min:
//                        shadowed), the thesis' min-max depth culling. Exact: the range
//                        holds every texel a deeper walk could read.
#define GBUFFER_BINDING 4  // gDepth, gNormal, GBufferCamera: plugin::bindGBuffer
#include "common/gbuffer.glsl"
#include "common/visibility.glsl"

#ifndef PCF_KERNEL
#define PCF_KERNEL 1
#endif
#ifndef ASM_DEPTH_CULLING
#define ASM_DEPTH_CULLING 1
#endif
// Compiled on its own (the every-shader test): a 128-texel tile, 16 columns.
#ifndef ASM_TILE
#define ASM_TILE 128
#define ASM_ATLAS_COLUMNS 16
#define ASM_MAX_LEVEL 10
#define ASM_PAGE_LEVEL 6
#endif

layout(local_size_x = 64, local_size_y = 1) in;

layout(binding = 1) uniform sampler2D atlas;  // the tiles' depths, one texel per fetch
layout(binding = 2, VISIBILITY_FORMAT) uniform writeonly image2D visibilityOut;

#define SHADOW_MAP_BINDING 3
#define SHADOW_RECEIVER_BIAS 0
#include "common/shadow_receiver.glsl"

#define ASM_NODES_BINDING 8
#define ASM_PAGES_BINDING 11
#define ASM_RANGES_BINDING 9
#include "asm_tree.glsl"

float asmTap(int node, vec2 local, float depth)
{
    return depth >= texelFetch(atlas, asmAtlasTexel(node, local), 0).r ? 1.0 : 0.0;
}

// One compare at light-view uv: the walk from the root down to the finest node of level
// at most maxLevel, stopped early by the depth ranges where they decide (exact at any
// node: a subtree's range holds its own tile's).
float asmCompare(uint face, vec2 uv, float depth, uint maxLevel)
{
    int node = asmPageNode(face, uv);
    if (asmTree.nodes[node].level > maxLevel) node = int(face);
    for (uint level = asmTree.nodes[node].level; level < maxLevel; ++level) {
#if ASM_DEPTH_CULLING
        vec4 range = asmRanges.ranges[node];
        if (depth >= range.w) return 1.0;
        if (depth < range.z) return 0.0;
#endif
        vec2 local = asmCellUv(node, uv);
        int child = asmTree.nodes[node].children[int(local.x >= 0.5) + 2 * int(local.y >= 0.5)];
        if (child < 0) break;
        node = child;
    }
    return asmTap(node, asmCellUv(node, uv), depth);
}

float filteredVisibility(ShadowReceiver r)
{
#if PCF_KERNEL == 1
    return asmCompare(r.face, r.uv, r.depth, uint(ASM_MAX_LEVEL));
#else
    // Percentage-closer filtering at the finest node's resolution. Taps beyond a cube
    // face's edge read its edge (the tile trees have no guard band).
    int centre = asmFinestNode(r.face, r.uv);
    uint centreLevel = asmTree.nodes[centre].level;
    vec2 local = asmCellUv(centre, r.uv);
    float step = asmTexelUv(centre);
    const int h = (PCF_KERNEL - 1) / 2;
    float lit = 0.0;
    for (int y = -h; y <= h; ++y)
        for (int x = -h; x <= h; ++x) {
            vec2 tap = local + vec2(x, y) / float(ASM_TILE);
            bool inside = all(greaterThanEqual(tap, vec2(0.0))) && all(lessThan(tap, vec2(1.0)));
            lit += inside ? asmTap(centre, tap, r.depth)
                          : asmCompare(r.face, clamp(r.uv + vec2(x, y) * step, vec2(0.0), vec2(1.0)), r.depth, centreLevel);
        }
    return lit / float(PCF_KERNEL * PCF_KERNEL);
#endif
}

void main()
{
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(visibilityOut);
    if (any(greaterThanEqual(pixel, size))) return;

    vec4 position = gbufferPosition(pixel);
    if (position.w == 0.0) {
        imageStore(visibilityOut, pixel, vec4(VISIBILITY_NO_GEOMETRY));
        return;
    }
    ShadowReceiver r;
    bool inMap = makeShadowReceiver(pixel, position.xyz, 0.0, r);
    float filtered = inMap ? filteredVisibility(r) : 1.0;
    float v = shadowVisibilityAboveHorizon(filtered, position.xyz, gbufferNormal(pixel));
    imageStore(visibilityOut, pixel, vec4(sanitizeVisibility(v)));
}
