// VSSM's min-max hierarchical shadow map (paper §3, §6.1: a mip chain, as the paper
// chooses over N-buffers). Level 0 is the depth map itself (each texel's normalised
// depth t is its own min and max); level k >= 1 holds the min and max of the (up to)
// 2 x 2 texels of level k - 1 below each texel, ceil(size / 2^k) texels per side. Levels
// 1 and up lie in one RG32F image (8 bytes a texel): level 1 at its origin, each level
// k >= 2 to the right of level 1, below level k - 1 (hsmLevelOrigin; vssm.cpp
// hsmImageSize gives the same layout's size). An image, not a buffer: the storage buffer
// range a device binds (lavapipe: 128 MiB) would cap the map's resolution (a rect light's
// six 4096^2 faces need 268 MiB of levels), while every map whose depth atlas is an image
// has a hierarchy image narrower than it.
//
// The including shader defines HSM_BINDING and HSM_QUALIFIER, and a function
// `float hsmLevel0(ivec2 texel)` giving t of an atlas texel of the depth map, first.
#ifndef PENUMBRA_VSSM_HSM_GLSL
#define PENUMBRA_VSSM_HSM_GLSL

layout(binding = HSM_BINDING, rg32f) uniform HSM_QUALIFIER image2D hsmImage;  // (min t, max t)

ivec2 hsmLevelSize(ivec2 size, int level) { return (size + (1 << level) - 1) >> level; }

// Where level `level` >= 1 starts in the image.
ivec2 hsmLevelOrigin(ivec2 size, int level)
{
    int y = 0;
    for (int k = 2; k < level; ++k) y += hsmLevelSize(size, k).y;
    return level <= 1 ? ivec2(0) : ivec2(hsmLevelSize(size, 1).x, y);
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
    return imageLoad(hsmImage, hsmLevelOrigin(size, level) + texel).xy;
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
    // The level's place in the image once, not per texel (hsmTexel walks the levels).
    ivec2 levelSize = hsmLevelSize(size, level);
    ivec2 origin = hsmLevelOrigin(size, level);
    vec2 range = vec2(1.0, 0.0);
    for (int y = a.y; y <= b.y; ++y)
        for (int x = a.x; x <= b.x; ++x) {
            ivec2 texel = clamp(ivec2(x, y), ivec2(0), levelSize - 1);
            vec2 v = level == 0 ? vec2(hsmLevel0(texel)) : imageLoad(hsmImage, origin + texel).xy;
            range = vec2(min(range.x, v.x), max(range.y, v.y));
        }
    return range;
}
#endif

#endif
