#version 460
// The adaptive shadow map's debug views (nothing reads them: the graph culls their passes
// unless one is requested).
//   DEBUG_VIEW 0, screen size:  tile_level: the level of the finest resident node over
//                               each G-buffer point (-1: no geometry or outside the map)
//   DEBUG_VIEW 1, light view (cube maps: the six faces in 3 x 2 cells of 256²):
//                               resident_tiles: 1 + the level of the finest resident node
//                               over each texel, 0 on the tiles' borders (their first
//                               row and column: cells of one texel show as border);
//                               tile_benefit: the analysis's benefit (sampled pixels) of
//                               the quadrant of that node that holds the texel, this frame
#define GBUFFER_BINDING 4
#include "common/gbuffer.glsl"

#ifndef ASM_TILE
#define ASM_TILE 128
#define ASM_ATLAS_COLUMNS 16
#define ASM_MAX_LEVEL 10
#define ASM_PAGE_LEVEL 6
#endif
#ifndef DEBUG_VIEW
#define DEBUG_VIEW 0
#endif

layout(local_size_x = 64, local_size_y = 1) in;

#define SHADOW_MAP_BINDING 3
#define SHADOW_RECEIVER_BIAS 0
#include "common/shadow_receiver.glsl"

#define ASM_NODES_BINDING 8
#define ASM_PAGES_BINDING 11
#include "asm_tree.glsl"

#if DEBUG_VIEW == 0
layout(binding = 1, r32f) uniform writeonly image2D tileLevel;
#else
layout(binding = 1, r32f) uniform writeonly image2D residentTiles;
layout(binding = 2, r32f) uniform writeonly image2D tileBenefit;
layout(std430, binding = 10) readonly buffer AsmAnalysis {
    uint counts[];
} analysis;
#endif

void main()
{
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
#if DEBUG_VIEW == 0
    if (any(greaterThanEqual(pixel, imageSize(tileLevel)))) return;
    vec4 position = gbufferPosition(pixel);
    ShadowReceiver r;
    bool inMap = position.w != 0.0 && makeShadowReceiver(pixel, position.xyz, 0.0, r);
    float level = inMap ? float(asmTree.nodes[asmFinestNode(r.face, r.uv)].level) : -1.0;
    imageStore(tileLevel, pixel, vec4(level));
#else
    ivec2 image = imageSize(residentTiles);
    if (any(greaterThanEqual(pixel, image))) return;
    // One face, or six cube faces in 3 x 2 cells as render::ShadowMap packs them.
    ivec2 cells = shadowFaceCount() == 6u ? ivec2(3, 2) : ivec2(1);
    ivec2 size = image / cells;
    ivec2 cell = pixel / size;
    uint face = uint(cell.x + 3 * cell.y);
    vec2 uv = (vec2(pixel - cell * size) + 0.5) / vec2(size);
    int node = asmFinestNode(face, uv);
    vec2 local = asmCellUv(node, uv);
    // The first debug texel row and column of the node's cell (each border drawn once, by
    // the cell right of or below it): a cell two debug texels wide keeps its level.
    vec2 border = exp2(float(asmTree.nodes[node].level)) / vec2(size);
    bool onBorder = any(lessThan(local, border));
    imageStore(residentTiles, pixel, vec4(onBorder ? 0.0 : float(asmTree.nodes[node].level) + 1.0));
    uint quadrant = uint(local.x >= 0.5) + 2u * uint(local.y >= 0.5);
    imageStore(tileBenefit, pixel, vec4(float(analysis.counts[uint(node) * 6u + 2u + quadrant])));
#endif
}
