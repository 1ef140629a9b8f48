// What the VSM family stores per shadow-map texel, and how a receiver reads it back.
// Depths are render::ShadowMap's normalised linear depth t in [0, 1] (distance along
// the light over the scene's depth range, shadowLinearDepth), so every constant below is
// independent of the scene's scale. Filtering (blur, mip levels, lookups) forms weighted
// sums (FilterSum): plain means for the moments of VSM and EVSM, log-space means for
// ESM's depths.
//
// Defines (vsm.cpp sets them; compiled on its own this is plain VSM):
//   VSM_VARIANT      0 vsm, 1 evsm, 2 esm
//   MOMENT_CHANNELS  2 or 4: EVSM with 2 stores the positive warp only
#ifndef PENUMBRA_VSM_MOMENTS_GLSL
#define PENUMBRA_VSM_MOMENTS_GLSL

#define VSM_VARIANT_VSM 0
#define VSM_VARIANT_EVSM 1
#define VSM_VARIANT_ESM 2

#ifndef VSM_VARIANT
#define VSM_VARIANT VSM_VARIANT_VSM
#endif
#ifndef MOMENT_CHANNELS
#define MOMENT_CHANNELS 2
#endif

const float kFloatMin = 1.17549435e-38;  // the smallest normal fp32

// The stored values for a caster at depth t. `exponents`: x the positive warp's c+ (ESM:
// its c), y the negative warp's c-; vsm.cpp has clamped EVSM's for the storage format.
vec4 warpDepth(float t, vec2 exponents)
{
#if VSM_VARIANT == VSM_VARIANT_VSM
    // Variance shadow maps (Donnelly & Lauritzen 2006): the first two moments.
    return vec4(t, t * t, 0.0, 0.0);
#elif VSM_VARIANT == VSM_VARIANT_EVSM
    // Exponential variance shadow maps (Lauritzen & McCool 2008, "Layered variance
    // shadow maps"): the moments of e^{c+ t'} and -e^{-c- t'}, t' = 2t - 1 in [-1, 1].
    float tw = 2.0 * t - 1.0;
    float positive = exp(exponents.x * tw);
    float negative = -exp(-exponents.y * tw);
    return vec4(positive, positive * positive, negative, negative * negative);
#else
    // Exponential shadow maps (Annen et al. 2008) prefilter e^{c z}; the depth itself is
    // stored here, and filters combine depths in log space (FilterSum), so that e^{c z}
    // is never formed: it overflows fp32 for c z > 88 and fp16 for c z > 11.
    return vec4(t, 0.0, 0.0, 0.0);
#endif
}

// Chebyshev's one-tailed inequality (Donnelly & Lauritzen 2006, eq. 5): for occluder
// depths with mean mu and variance sigma^2, the fraction at least as far as t is at most
// p_max = sigma^2 / (sigma^2 + (t - mu)^2) where t > mu. The variance is clamped below
// by `minVariance` (rounding in E[x^2] - E[x]^2 may give 0 or less on a flat receiver,
// which would then shadow itself); the denominator cannot reach 0.
float chebyshevUpperBound(vec2 moments, float t, float minVariance)
{
    if (t <= moments.x) return 1.0;
    float variance = max(moments.y - moments.x * moments.x, minVariance);
    float d = t - moments.x;
    return variance / max(variance + d * d, kFloatMin);
}

// Light-bleeding reduction (Lauritzen, GPU Gems 3 ch. 8): p_max below `amount` is cut to
// 0 and the rest rescaled, linstep(amount, 1, p_max). amount < 1 (the parameter's
// range); the guard keeps the division finite all the same.
float reduceLightBleeding(float p, float amount)
{
    return clamp((p - amount) / max(1.0 - amount, 1e-6), 0.0, 1.0);
}

// A minimum variance given for t, carried through a warp w(t) with derivative dw/dt:
// sigma_w = sigma dw/dt to first order. The product is clamped below sqrt(FLT_MAX) / 2 so
// that its square, and the Chebyshev denominator after it, stay finite.
float warpedMinVariance(float minVariance, float dWarpDt)
{
    float sigma = min(sqrt(minVariance) * abs(dWarpDt), 9.0e18);
    return sigma * sigma;
}

// A weighted sum of stored values, as every filter forms it (blur taps, mip texels,
// bilinear, trilinear and anisotropic lookups). VSM and EVSM store moments, and the
// weighted mean of moments is what Chebyshev's bound needs. ESM's prefiltered value is
// z_f = (1/c) ln(sum w_i e^{c z_i} / sum w_i): kept as the largest depth m so far and
// sum w_i e^{c (z_i - m)}, every exponent <= 0, so nothing overflows for any c and the
// sum stays >= the largest depth's weight (its logarithm is finite). `exponent`: ESM's c.
struct FilterSum {
    vec4 sum;        // VSM, EVSM: sum w_i m_i. ESM: x sum w_i e^{c (z_i - m)}, y sum w_i z_i
    float weight;    // sum w_i
    float maxDepth;  // ESM: m
};

FilterSum emptyFilterSum() { return FilterSum(vec4(0.0), 0.0, 0.0); }

void addToFilter(inout FilterSum f, vec4 value, float weight, float exponent)
{
    if (!(weight > 0.0)) return;
#if VSM_VARIANT == VSM_VARIANT_ESM
    float z = value.x;
    if (f.weight == 0.0) {
        f.maxDepth = z;
        f.sum.x = weight;
    } else if (z > f.maxDepth) {
        f.sum.x = f.sum.x * exp(exponent * (f.maxDepth - z)) + weight;
        f.maxDepth = z;
    } else {
        f.sum.x += weight * exp(exponent * (z - f.maxDepth));
    }
    f.sum.y += weight * z;
#else
    f.sum += weight * value;
#endif
    f.weight += weight;
}

// The filtered value (0 for an empty sum). ESM with c near 0: the log-space mean tends
// to the plain mean, used below 1e-6 (no division by c).
vec4 filterResult(FilterSum f, float exponent)
{
    if (!(f.weight > 0.0)) return vec4(0.0);
#if VSM_VARIANT == VSM_VARIANT_ESM
    float z = exponent > 1e-6 ? f.maxDepth + log(f.sum.x / f.weight) / exponent : f.sum.y / f.weight;
    return vec4(z, 0.0, 0.0, 0.0);
#else
    return f.sum / f.weight;
#endif
}

// The fraction of light at a receiver of depth t, from filtered stored values.
// `exponents` as warpDepth's.
float momentVisibility(vec4 moments, float t, vec2 exponents, float minVariance, float bleedingReduction)
{
#if VSM_VARIANT == VSM_VARIANT_VSM
    return reduceLightBleeding(chebyshevUpperBound(moments.xy, t, minVariance), bleedingReduction);
#elif VSM_VARIANT == VSM_VARIANT_EVSM
    // Each warp gives an upper bound; both hold, so the smaller is kept. The warps grow
    // with t, so the one-tailed test keeps its direction.
    vec4 warped = warpDepth(t, exponents);
    float p = chebyshevUpperBound(moments.xy, warped.x,
                                  warpedMinVariance(minVariance, 2.0 * exponents.x * warped.x));
#if MOMENT_CHANNELS == 4
    p = min(p, chebyshevUpperBound(moments.zw, warped.z,
                                   warpedMinVariance(minVariance, 2.0 * exponents.y * warped.z)));
#endif
    return reduceLightBleeding(p, bleedingReduction);
#else
    // ESM: V = E[e^{c (z - t)}] = e^{c (z_f - t)}, its exponent clamped at 0 (the
    // estimate says "lit" there), so exp() lies in [0, 1] for any c and depth.
    return exp(min(exponents.x * (moments.x - t), 0.0));
#endif
}

#endif
