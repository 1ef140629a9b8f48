// VSSM's summed-area table (Crow 1984) of the moments (t, t^2) of the map's normalised
// depths t (shadowLinearDepth, in [0, 1]): for any box, its mean E(t), E(t^2) and so the
// variance that Chebyshev's inequality needs (paper §3, §6.4).
//
// Precision (paper §6.4: fp32 prefix sums lose the variance at 1024^2 and above; the
// paper uses 32-bit integers, Lauritzen 2007): a box's sums are differences of four
// table entries, each the sum over a quadrant of the whole map, so an fp32 table rounds
// each box by the ulp of the map's sum: a 2048^2 map of t ~ 0.5 sums to 2^21, whose ulp
// 0.25 is the error of a 3 x 3 box's sum, about 0.03 in its mean and far more than any
// variance Chebyshev must resolve (1e-6). 32-bit integers sum exactly but leave 32 bits
// for the whole map: 2^-10 per texel at 4096^2, again coarser than the variances.
//
// Here each texel's t and t^2 are rounded once to 2^-31 (kSatFractionBits) and summed in
// 64-bit unsigned integers, exactly: t <= 1 gives at most 2^31 per texel, and the
// largest atlas the plugin allows (3 x 2 faces of 8192^2, 2^28.6 texels) sums to below
// 2^60. A box's sums are then exact for the rounded depths, so its mean and E(t^2) are
// within 2^-32 of those of the map's fp32 depths whatever the map's size, and its
// variance within about 2^-31 (tests/techniques/test_vssm_plugin.cpp measures it against fp64 at
// 512^2, 2048^2 and 4096^2). Boxes with fractional edges (the kernels are not
// texel-aligned) interpolate the table bilinearly, which is the exact integral of the
// piecewise-constant map; that arithmetic runs in fp64 on entries relative to the box's
// first corner, which stay below 2^53 (exact) for boxes up to (2^53 / 2^31) / (the map's
// side) texels tall and wide: 1024 at 4096^2.
//
// The including shader defines SAT_BINDING, and SAT_QUALIFIER as readonly (the lookups:
// also define SAT_READ_ONLY) or empty (the scan that writes it), first.
#ifndef PENUMBRA_VSSM_SAT_GLSL
#define PENUMBRA_VSSM_SAT_GLSL

#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

#ifndef SAT_BINDING
#error vssm/sat.glsl: define SAT_BINDING first
#endif
#ifndef SAT_QUALIFIER
#define SAT_QUALIFIER readonly
#endif

const int kSatFractionBits = 31;
const double kSatScale = 2147483648.0lf;  // 2^kSatFractionBits

// Entry (x, y): the sums over the atlas texels x' <= x, y' <= y, as (low, high) words
// of the two 64-bit sums. An image rather than a buffer: a 4096^2 table is 256 MiB,
// beyond the storage buffer range many devices bind (lavapipe: 128 MiB).
layout(binding = SAT_BINDING, rgba32ui) uniform SAT_QUALIFIER uimage2D satImage;

u64vec2 satLoad(ivec2 texel)
{
    uvec4 v = imageLoad(satImage, texel);
    return u64vec2(packUint2x32(v.xy), packUint2x32(v.zw));
}

#ifndef SAT_READ_ONLY
void satStore(ivec2 texel, u64vec2 sums)
{
    imageStore(satImage, texel, uvec4(unpackUint2x32(sums.x), unpackUint2x32(sums.y)));
}
#endif

// One depth's fixed-point moments: t and t^2 of the rounded t, each rounded to 2^-31.
// t^2 comes from the integer t (a^2 <= 2^62, no overflow), so the moments belong to one
// depth and a box of equal depths has variance 0 up to the rounding of t^2.
u64vec2 satFixedMoments(float t)
{
    uint64_t a = uint64_t(double(clamp(t, 0.0, 1.0)) * kSatScale + 0.5lf);
    uint64_t b = (a * a + (uint64_t(1) << (kSatFractionBits - 1))) >> kSatFractionBits;
    return u64vec2(a, b);
}

// The sums over texels x' < corner.x, y' < corner.y (a lattice corner; 0 on the low
// edges). Corners beyond the far edges are clamped to them; callers only give them
// weight 0 there.
u64vec2 satCorner(ivec2 corner, ivec2 size)
{
    corner = min(corner, size);
    if (corner.x <= 0 || corner.y <= 0) return u64vec2(uint64_t(0));
    return satLoad(corner - 1);
}

// The integral of the map over [0, p.x) x [0, p.y) minus `base` (a corner at or below
// floor(p) on both axes, so the difference is a sum of non-negative texels), in fixed
// point units: bilinear in the four surrounding corners, which is exact for a
// piecewise-constant map.
dvec2 satIntegral(vec2 p, u64vec2 base, ivec2 size)
{
    ivec2 i = ivec2(floor(p));
    double fx = double(p.x - float(i.x)), fy = double(p.y - float(i.y));
    u64vec2 e00 = satCorner(i, size) - base, e10 = satCorner(i + ivec2(1, 0), size) - base;
    u64vec2 e01 = satCorner(i + ivec2(0, 1), size) - base, e11 = satCorner(i + ivec2(1, 1), size) - base;
    dvec2 s00 = dvec2(double(e00.x), double(e00.y)), s10 = dvec2(double(e10.x), double(e10.y));
    dvec2 s01 = dvec2(double(e01.x), double(e01.y)), s11 = dvec2(double(e11.x), double(e11.y));
    return mix(mix(s00, s10, fx), mix(s01, s11, fx), fy);
}

// A box's moments (satBox).
struct SatMoments {
    float mean;
    float meanSquare;
    float variance;
    float area;
};

// The box [lo, hi) in atlas texels (real edges, lo <= hi, inside [0, size]): (mean
// E(t), E(t^2), variance E(t^2) - E(t)^2 >= 0, area in texels), in fp64. An empty box
// has area 0 and the moments of a lit texel (t = 1): callers skip it.
// The moments of a box from its sums (fixed-point units, satIntegral differences) and
// its area: (mean, E(t^2), variance, area); an empty box gives a lit texel's, area 0.
dvec4 satMomentsOfSums(dvec2 sum, double area)
{
    if (!(area > 0.0lf)) return dvec4(1.0lf, 1.0lf, 0.0lf, 0.0lf);
    double mean = sum.x / (kSatScale * area), meanSquare = sum.y / (kSatScale * area);
    return dvec4(mean, meanSquare, max(meanSquare - mean * mean, 0.0lf), area);
}

dvec4 satBoxMoments(vec2 lo, vec2 hi, ivec2 size)
{
    double area = double(max(hi.x - lo.x, 0.0)) * double(max(hi.y - lo.y, 0.0));
    if (!(area > 0.0lf)) return satMomentsOfSums(dvec2(0.0lf), 0.0lf);
    u64vec2 base = satCorner(ivec2(floor(lo)), size);
    dvec2 sum = satIntegral(hi, base, size) - satIntegral(vec2(lo.x, hi.y), base, size) -
                satIntegral(vec2(hi.x, lo.y), base, size) + satIntegral(lo, base, size);
    return satMomentsOfSums(sum, area);
}

// The same in fp32 for the lookups: the variance is formed in fp64 first, so it keeps
// its own relative precision.
SatMoments satMoments(dvec4 m) { return SatMoments(float(m.x), float(m.y), float(m.z), float(m.w)); }

SatMoments satBox(vec2 lo, vec2 hi, ivec2 size) { return satMoments(satBoxMoments(lo, hi, size)); }

#endif
