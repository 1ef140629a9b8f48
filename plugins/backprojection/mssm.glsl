// The multi-scale shadow map (Schwarz and Stamminger 2007, "Bitmask soft shadows"), built
// on the dual grid as Yang et al. 2009 §4.2 build it: node (c, l) holds the least and the
// largest stored depth (reversed-Z NDC: larger is nearer the light) of every shadow-map
// sample of the 2^l x 2^l dual cells [c, c + 2^l) of its face. Dual cell c is the 2 x 2
// block of samples c, c + (1, 0), c + (0, 1), c + (1, 1): the block marching squares
// reads (contour.glsl). So level 0 is every block's range, and any power-of-two square
// of cells is one fetch, any rectangle a few (mssmRange). Every level has a node per
// atlas texel (full resolution), anchored at its top-left cell, so the quadtree that the
// hierarchical traversal instantiates starts exactly at a kernel's corner.
//
// Cells and nodes never cross a face of a cube atlas: a sample or child past the face's
// last one is clamped to it (that node covers fewer cells).
//
// One RG32F storage image array, a layer per level, each as large as the atlas (level
// l's node for atlas cell c at (c, l)): an image is not bound by a device's largest
// storage buffer range (lavapipe: 128 MiB, which a 1024-texel cube atlas's 7 levels
// exceed), and an array's layers are each bound only by the largest 2-D image side, which
// the atlas already fits; what remains is the device's largest allocation
// (backprojection.cpp checks it). A second depth layer's MSSM (visibility.comp LAYERS)
// takes the layers after the first's: its readers and its builder (mssm.comp) start at
// its first layer, `base`.
//
// The including shader defines MSSM_BINDING and MSSM_QUALIFIER first.
#ifndef PENUMBRA_BACKPROJECTION_MSSM_GLSL
#define PENUMBRA_BACKPROJECTION_MSSM_GLSL

// (least NDC depth, largest NDC depth) per node.
layout(binding = MSSM_BINDING, rg32f) uniform MSSM_QUALIFIER image2DArray mssmImage;

// `base`: the depth layer's first array layer (its level 0).
ivec3 mssmTexel(int base, int level, ivec2 cell)
{
    return ivec3(cell, base + level);
}

vec2 mssmNode(int base, int level, ivec2 cell)
{
    return imageLoad(mssmImage, mssmTexel(base, level, cell)).xy;
}

// The last cell (and sample) of the face that holds atlas cell `cell`.
ivec2 mssmFaceLast(ivec2 cell, int faceTexels)
{
    return (cell / faceTexels) * faceTexels + (faceTexels - 1);
}

#ifndef MSSM_WRITES
// The range of depths over the cells [lo, hi] (inclusive, one face) at the level whose
// nodes are no wider than the narrower side: at most 2 x 2 fetches for a square, and a
// few more along the longer side of a rectangle. `levels`: how many the image holds a
// depth layer.
vec2 mssmRange(int base, int levels, ivec2 lo, ivec2 hi)
{
    ivec2 extent = max(hi - lo + 1, ivec2(1));
    int level = min(findMSB(min(extent.x, extent.y)), levels - 1);
    int step = 1 << level;
    ivec2 count = (extent + step - 1) / step;
    vec2 range = vec2(1.0, 0.0);
    for (int j = 0; j < count.y; ++j)
        for (int i = 0; i < count.x; ++i) {
            ivec2 node = max(min(lo + ivec2(i, j) * step, hi - step + 1), lo);
            vec2 v = mssmNode(base, level, node);
            range = vec2(min(range.x, v.x), max(range.y, v.y));
        }
    return range;
}
#endif

#endif
