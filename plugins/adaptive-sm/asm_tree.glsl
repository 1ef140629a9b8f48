// The adaptive shadow map's quadtrees as its shaders read them (plugins/adaptive-sm/
// tile_tree.h is the CPU side): one per light view (face f of render::ShadowMap: one, or
// six cube faces), its root node f. A node at level L, cell (x, y) covers its face's uv
// square [x, x + 1) / 2^L x [y, y + 1) / 2^L with one ASM_TILE² tile of reversed-Z depth
// in the atlas (slot s at column s % ASM_ATLAS_COLUMNS, row s / ASM_ATLAS_COLUMNS); its
// children split the cell in quadrants q = qx + 2 qy. A lookup walks from its face's root
// to the finest resident node over its point.
//
// The including shader defines ASM_TILE, ASM_ATLAS_COLUMNS, ASM_MAX_LEVEL and
// ASM_NODES_BINDING (the node table), ASM_PAGE_LEVEL and ASM_PAGES_BINDING for the page
// table where it walks the trees, and ASM_RANGES_BINDING for the depth ranges (with
// ASM_RANGES_WRITABLE when it writes them).
#ifndef PENUMBRA_ASM_TREE_GLSL
#define PENUMBRA_ASM_TREE_GLSL

struct AsmNode {
    ivec4 children;  // slot per quadrant, -1: none
    uint level;
    uint x;
    uint y;
    uint face;  // 0xffffffff: a free slot, never reached from a root
};

layout(std430, binding = ASM_NODES_BINDING) readonly buffer AsmNodes {
    AsmNode nodes[];
} asmTree;

#ifdef ASM_RANGES_BINDING
// Per node: x, y the min and max depth of its own tile, z, w of its tile and every
// resident descendant's (the thesis' min-max depth culling).
#ifdef ASM_RANGES_WRITABLE
layout(std430, binding = ASM_RANGES_BINDING) coherent buffer AsmRanges {
#else
layout(std430, binding = ASM_RANGES_BINDING) readonly buffer AsmRanges {
#endif
    vec4 ranges[];
} asmRanges;
#endif

#ifdef ASM_PAGES_BINDING
// The page table (adaptive_sm.cpp writes it with the node table): per face, for each cell
// of level ASM_PAGE_LEVEL (row-major, 2^ASM_PAGE_LEVEL across), the finest resident node
// whose cell holds that whole cell. A walk starts there instead of at the root: the same
// path, up to ASM_PAGE_LEVEL steps shorter.
layout(std430, binding = ASM_PAGES_BINDING) readonly buffer AsmPages {
    int pages[];
} asmPages;

int asmPageNode(uint face, vec2 uv)
{
    const int side = 1 << ASM_PAGE_LEVEL;
    ivec2 cell = clamp(ivec2(uv * float(side)), ivec2(0), ivec2(side - 1));
    return asmPages.pages[int(face) * side * side + cell.y * side + cell.x];
}
#endif

// The uv of `uv` inside node `node`'s cell: [0, 1)² when the cell holds it. The scale is a
// power of two and the cell's corner an integer, so this is exact up to uv's own rounding.
vec2 asmCellUv(int node, vec2 uv)
{
    AsmNode n = asmTree.nodes[node];
    return uv * exp2(float(n.level)) - vec2(n.x, n.y);
}

// The finest resident node of `face` whose cell holds uv (uv in [0, 1]²).
int asmFinestNode(uint face, vec2 uv)
{
#ifdef ASM_PAGES_BINDING
    int node = asmPageNode(face, uv);
#else
    int node = int(face);
#endif
    for (int i = 0; i < ASM_MAX_LEVEL; ++i) {
        vec2 local = asmCellUv(node, uv);
        int quadrant = int(local.x >= 0.5) + 2 * int(local.y >= 0.5);
        int child = asmTree.nodes[node].children[quadrant];
        if (child < 0) break;
        node = child;
    }
    return node;
}

// The atlas texel of node `node` at cell uv `local` (clamped into the tile).
ivec2 asmAtlasTexel(int node, vec2 local)
{
    ivec2 texel = clamp(ivec2(floor(local * float(ASM_TILE))), ivec2(0), ivec2(ASM_TILE - 1));
    return ivec2(node % ASM_ATLAS_COLUMNS, node / ASM_ATLAS_COLUMNS) * ASM_TILE + texel;
}

// World-independent size of one texel of `node`, in light-view uv.
float asmTexelUv(int node)
{
    return exp2(-float(asmTree.nodes[node].level)) / float(ASM_TILE);
}

#endif
