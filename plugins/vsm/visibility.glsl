// The VSM family's lookup, as its visibility function (plugin/VisibilityFunction.h): a
// G-buffer position is projected into the light's map, and its normalised depth t
// compared with the filtered stored values there (moments.glsl momentVisibility).
//
// Defines (vsm.cpp sets them; compiled on its own: plain VSM, one blurred map):
//   FILTER   0 blur: one bilinear lookup in the blurred map (blur.comp ran before)
//            1 trilinear: the pixel's footprint in the map picks a level of the mip
//              chain (downsample.comp), two bilinear lookups blended
//            2 anisotropic: up to max_anisotropy trilinear lookups along the
//              footprint's long axis, at the level of its short one
//   LEVELS   mip levels bound (1 for FILTER 0), at most 15
//   VSM_VARIANT, MOMENT_CHANNELS (moments.glsl)
// and the parameters: EXPONENTS (moments.glsl warpDepth), MIN_VARIANCE (in t^2),
// BLEEDING_REDUCTION (in [0, 1)), LOD_BIAS (levels added to the footprint's, FILTER 1, 2),
// MAX_ANISOTROPY (lookups along the footprint, FILTER 2, >= 1).
#include "moments.glsl"

#define FILTER_BLUR 0
#define FILTER_TRILINEAR 1
#define FILTER_ANISOTROPIC 2
#ifndef FILTER
#define FILTER FILTER_BLUR
#endif
#ifndef LEVELS
#define LEVELS 1
#endif
#if LEVELS < 1 || LEVELS > 15 || (FILTER == FILTER_BLUR && LEVELS != 1)
#error LEVELS must be 1 with FILTER 0 and in 1..15 otherwise
#endif
#ifndef EXPONENTS
#define EXPONENTS vec2(0.0)
#define MIN_VARIANCE 1e-6
#define BLEEDING_REDUCTION 0.0
#define LOD_BIAS 0.0
#define MAX_ANISOTROPY 1.0
#endif

// Level k has faceTexels / 2^k texels per face; each its own image (a graph resource).
layout(binding = VISIBILITY_BINDING(0)) uniform sampler2D momentLevels[LEVELS];

#define SHADOW_MAP_BINDING VISIBILITY_BINDING(1)
#define SHADOW_RECEIVER_BIAS 0
#if FILTER != FILTER_BLUR
#define SHADOW_SURFACE_NEIGHBOURS
#endif
#include "common/shadow_receiver.glsl"

// A bilinear lookup in mip level `level`, kept half a texel of that level inside the
// face, added to `f` with `weight`. VSM and EVSM: the sampler's bilinear filter. ESM:
// the four texels (textureGather) with bilinear weights, added in log space. Arrays of
// samplers may only be indexed by constants here (no descriptor indexing on every
// device): one case per level.
#if VSM_VARIANT == VSM_VARIANT_ESM
#define ADD_LEVEL(k)                                                                    \
    {                                                                                   \
        vec2 st = uv * vec2(textureSize(momentLevels[k], 0)) - 0.5;                     \
        vec2 w = st - floor(st);                                                        \
        vec4 z = textureGather(momentLevels[k], uv, 0); /* (0,1) (1,1) (1,0) (0,0) */   \
        addToFilter(f, vec4(z.w), (1.0 - w.x) * (1.0 - w.y) * weight, EXPONENTS.x);  \
        addToFilter(f, vec4(z.z), w.x * (1.0 - w.y) * weight, EXPONENTS.x);          \
        addToFilter(f, vec4(z.x), (1.0 - w.x) * w.y * weight, EXPONENTS.x);          \
        addToFilter(f, vec4(z.y), w.x * w.y * weight, EXPONENTS.x);                  \
        return;                                                                         \
    }
#else
#define ADD_LEVEL(k)                                                                    \
    {                                                                                   \
        addToFilter(f, textureLod(momentLevels[k], uv, 0.0), weight, EXPONENTS.x);   \
        return;                                                                         \
    }
#endif
void addLevel(inout FilterSum f, uint face, vec2 faceUv, int level, float weight)
{
    float texels = max(shadowFaceTexels() / float(1 << level), 1.0);
    vec2 uv = shadowAtlasUv(face, shadowClampToFace(faceUv, 0.5, texels));
    switch (level) {
    case 0: ADD_LEVEL(0)
#if LEVELS > 1
    case 1: ADD_LEVEL(1)
#endif
#if LEVELS > 2
    case 2: ADD_LEVEL(2)
#endif
#if LEVELS > 3
    case 3: ADD_LEVEL(3)
#endif
#if LEVELS > 4
    case 4: ADD_LEVEL(4)
#endif
#if LEVELS > 5
    case 5: ADD_LEVEL(5)
#endif
#if LEVELS > 6
    case 6: ADD_LEVEL(6)
#endif
#if LEVELS > 7
    case 7: ADD_LEVEL(7)
#endif
#if LEVELS > 8
    case 8: ADD_LEVEL(8)
#endif
#if LEVELS > 9
    case 9: ADD_LEVEL(9)
#endif
#if LEVELS > 10
    case 10: ADD_LEVEL(10)
#endif
#if LEVELS > 11
    case 11: ADD_LEVEL(11)
#endif
#if LEVELS > 12
    case 12: ADD_LEVEL(12)
#endif
#if LEVELS > 13
    case 13: ADD_LEVEL(13)
#endif
#if LEVELS > 14
    case 14: ADD_LEVEL(14)
#endif
    }
}

#if FILTER != FILTER_BLUR
// The pixel's footprint in the map, in texels of level 0 per pixel step along the
// screen's x (dx) and y (dy): where the neighbours on the same surface project. Where
// one axis has no such neighbour (the surface's edge) the footprint is taken as round;
// where neither has (a surface one pixel wide, a curved one at pixel scale) it is zero
// and the finest level is read.
void footprint(ivec2 pixel, vec3 p, ShadowReceiver r, out vec2 dx, out vec2 dy)
{
    dx = vec2(0.0);
    dy = vec2(0.0);
    vec3 n = gbufferNormal(pixel);
    if (dot(n, n) == 0.0) return;
    vec3 q, a;
    float w;
    if (shadowSurfaceNeighbour(pixel, ivec2(1, 0), p, n, q) && shadowProject(r.face, q, a, w))
        dx = (a.xy - r.uv) * shadowFaceTexels();
    if (shadowSurfaceNeighbour(pixel, ivec2(0, 1), p, n, q) && shadowProject(r.face, q, a, w))
        dy = (a.xy - r.uv) * shadowFaceTexels();
    if (dot(dx, dx) == 0.0) dx = vec2(-dy.y, dy.x);
    if (dot(dy, dy) == 0.0) dy = vec2(-dx.y, dx.x);
}
#endif

vec4 filteredMoments(ShadowReceiver r, ivec2 pixel, vec3 p)
{
    FilterSum f = emptyFilterSum();
#if FILTER == FILTER_BLUR
    addLevel(f, r.face, r.uv, 0, 1.0);
#else
    vec2 dx, dy;
    footprint(pixel, p, r, dx, dy);
    float lx = length(dx), ly = length(dy);
    vec2 major = lx >= ly ? dx : dy;
    float majorTexels = max(lx, ly), minorTexels = min(lx, ly);
#if FILTER == FILTER_ANISOTROPIC
    // Lookups spaced majorTexels / count along the long axis, each as wide as that
    // spacing or the short axis, whichever is larger (software anisotropic filtering).
    float count = clamp(ceil(majorTexels / max(minorTexels, 1e-6)), 1.0, MAX_ANISOTROPY);
    float widthTexels = max(majorTexels / count, minorTexels);
#else
    float count = 1.0;
    float widthTexels = majorTexels;
#endif
    // Level log2(width): one texel of it covers the footprint. A zero footprint gives
    // log2(1e-6) < 0: the finest level.
    float lod = clamp(log2(max(widthTexels, 1e-6)) + LOD_BIAS, 0.0, float(LEVELS - 1));
    int finer = int(lod);
    int coarser = min(finer + 1, LEVELS - 1);
    float blend = lod - float(finer);
    for (float i = 0.0; i < count; i += 1.0) {
        vec2 uv = r.uv + major / shadowFaceTexels() * ((i + 0.5) / count - 0.5);
        addLevel(f, r.face, uv, finer, 1.0 - blend);
        addLevel(f, r.face, uv, coarser, blend);
    }
#endif
    return filterResult(f, EXPONENTS.x);
}

// Straight-line: every pixel runs the same code and the results are selected at the end
// (common/shadow_map.glsl: uniform loads). The horizon (every filter) and the footprint
// (mips) read the normal.
float techniqueVisibility(ivec2 pixel, vec3 position, vec3 normal)
{
    ShadowReceiver r;
    bool inMap = makeShadowReceiver(pixel, position, 0.0, r);
    float t = shadowLinearDepth(r.face, r.depth);
    float moments = momentVisibility(filteredMoments(r, pixel, position), t, EXPONENTS, MIN_VARIANCE, BLEEDING_REDUCTION);
    return shadowVisibilityAboveHorizon(inMap ? moments : 1.0, position, normal);
}
