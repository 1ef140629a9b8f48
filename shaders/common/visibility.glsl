// The one contract between the engine and a shadow technique (DESIGN.md): for each light
// a screen-space image V_l, one float per pixel, holding the fraction of that light that
// reaches the surface seen in the pixel: 1 lit, 0 umbra, in between for penumbrae and
// translucent casters. Pixels that see no geometry hold 1. Stored as R16_UNORM (was
// R32F): steps of 1/65535, so a stored value is within 7.7e-6 of the written one, and
// half the bytes for every writer and reader. `penumbra compare` on config/default.json,
// pcss.json and vsm.json (320 x 180, against the R32F engine in one run, with the
// rebuilt G-buffer positions of the same change) moved no error figure by more than
// 3e-5 and the regions by one pixel (pcss: one from umbra to penumbra). R16F was measured too: it keeps 0.25, 0.5
// and 0.75 exact but rounds values near 1 by up to 2.4e-4 (vsm.json's MAE 0.00321 ->
// 0.00347).
//
// Light from below the surface's tangent plane (the G-buffer normal's, facing the
// camera) counts as blocked: the surface itself stands in its way. So a surface facing
// away from the whole light holds 0, whatever the casters, and one that a rect light
// straddles holds at most the part of the light above it (shadowLightAboveHorizon in
// common/shadow_map.glsl; the reference tests every sample).
#ifndef PENUMBRA_VISIBILITY_GLSL
#define PENUMBRA_VISIBILITY_GLSL

#define VISIBILITY_FORMAT r16
#define VISIBILITY_NO_GEOMETRY 1.0

// Every writer clamps: a technique may never hand the shading pass a NaN or a value
// outside [0, 1] (NaN fails every comparison, so it maps to 0 here, then to the clamp).
float sanitizeVisibility(float v)
{
    return (v >= 0.0) ? min(v, 1.0) : 0.0;
}

// What a VISIBILITY_FORMAT image holds of v in [0, 1], as a read returns it: where
// shading evaluates a technique's visibility itself it sees the very value the image
// would have given (tests/engine/frame/test_visibility_in_shading.cpp checks it against
// every 16-bit code on the device).
float visibilityAsStored(float v)
{
    return round(v * 65535.0) / 65535.0;
}

#endif
