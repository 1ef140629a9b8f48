// VSSM's min-max hierarchical shadow map (paper §3, §6.1: a mip chain, as the paper
// chooses over N-buffers). Level 0 is the depth map itself (each texel's normalised
// depth t is its own min and max); level k >= 1 holds the min and max of the (up to)
// 2 x 2 texels of level k - 1 below each texel, ceil(size / 2^k) texels per side. Levels
// 1 and up lie in one buffer, level after level (a third of the map's texels, 8 bytes
// each).
//
// The including shader defines HSM_BINDING and HSM_QUALIFIER, and a function
// `float hsmLevel0(ivec2 texel)` giving t of an atlas texel of the depth map, first.
#ifndef PENUMBRA_VSSM_HSM_GLSL
#define PENUMBRA_VSSM_HSM_GLSL

layout(std430, binding = HSM_BINDING) HSM_QUALIFIER buffer HsmBuffer {
    vec2 hsmTexels[];  // (min t, max t)
};

ivec2 hsmLevelSize(ivec2 size, int level) { return (size + (1 << level) - 1) >> level; }

// Where level `level` >= 1 starts in the buffer.
int hsmLevelOffset(ivec2 size, int level)
{
    int offset = 0;
    for (int k = 1; k < level; ++k) {
        ivec2 s = hsmLevelSize(size, k);
        offset += s.x * s.y;
    }
    return offset;
}

// The levels down to one texel, level 0 included.
int hsmLevelCount(ivec2 size)
{
    int levels = 1;
    while (any(greaterThan(hsmLevelSize(size, levels - 1), ivec2(1)))) ++levels;
    return levels;
}

// Texel `texel` of level `level` (clamped into it): (min t, max t).
vec2 hsmTexel(ivec2 size, int level, ivec2 texel)
{
    ivec2 levelSize = hsmLevelSize(size, level);
    texel = clamp(texel, ivec2(0), levelSize - 1);
    if (level == 0) return vec2(hsmLevel0(texel));
    return hsmTexels[hsmLevelOffset(size, level) + texel.y * levelSize.x + texel.x];
}

#ifndef HSM_WRITES
// The min and max of t over the atlas texels [first, last] (inclusive): read at the
// level where the range spans at most two texels per axis, so at most four lookups.
// They cover a superset of the range, so the bounds are conservative (they never claim
// lit or umbra wrongly).
vec2 hsmRange(ivec2 first, ivec2 last, ivec2 size)
{
    int levels = hsmLevelCount(size);
    int extent = max(last.x - first.x, last.y - first.y) + 1;
    int level = 0;
    while ((1 << level) < extent && level < levels - 1) ++level;
    ivec2 a = first >> level, b = last >> level;
    // The level's place in the buffer once, not per texel (hsmTexel walks the levels).
    ivec2 levelSize = hsmLevelSize(size, level);
    int offset = level > 0 ? hsmLevelOffset(size, level) : 0;
    vec2 range = vec2(1.0, 0.0);
    for (int y = a.y; y <= b.y; ++y)
        for (int x = a.x; x <= b.x; ++x) {
            ivec2 texel = clamp(ivec2(x, y), ivec2(0), levelSize - 1);
            vec2 v = level == 0 ? vec2(hsmLevel0(texel)) : hsmTexels[offset + texel.y * levelSize.x + texel.x];
            range = vec2(min(range.x, v.x), max(range.y, v.y));
        }
    return range;
}
#endif

#endif
