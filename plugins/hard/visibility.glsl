// Hard shadow-map lookup for one light, as its visibility function
// (plugin/VisibilityFunction.h): a G-buffer position is projected into the light's depth
// map and compared, and the fraction of passing compares is V_l. The engine runs it as
// the visibility pass or inside shading.
//
// The map is render::ShadowMap's (shaders/common/shadow_map.glsl): reversed-Z, so a
// receiver is lit where its light-space depth is >= the stored caster depth (the
// sampler's compareOp GREATER_OR_EQUAL), and "towards the light" is towards larger
// depth; one face, or six cube faces in a 3 x 2 atlas. The receiver and its bias are
// shaders/common/shadow_receiver.glsl's.
//
// The variant is chosen by defines (plugins/hard/visibility_pass.h sets them):
//   FILTER         0 none: one nearest compare
//                  1 pcf: PCF_KERNEL x PCF_KERNEL nearest compares at texel spacing
//                  2 poisson: POISSON_SAMPLES compares on a disk of filterRadiusTexels,
//                    rotated per pixel
//                  3 bilinear: one 2 x 2 compare with bilinear weights
//   RECEIVER_BIAS  0 none (constant and slope-scaled bias are the rasterizer's)
//                  1 normal offset
//                  2 receiver plane depth bias
// and its parameters by NORMAL_OFFSET_TEXELS (RECEIVER_BIAS 1) and FILTER_RADIUS_TEXELS
// (FILTER 2).

#define FILTER_NONE 0
#define FILTER_PCF 1
#define FILTER_POISSON 2
#define FILTER_BILINEAR 3

// The plugin always defines both (plugins/hard/visibility_pass.h); compiled on its own
// (a shader tool, the engine's every-shader test) this is the default variant.
#ifndef FILTER
#define FILTER FILTER_NONE
#endif
#ifndef RECEIVER_BIAS
#define RECEIVER_BIAS 0
#endif
#ifndef NORMAL_OFFSET_TEXELS
#define NORMAL_OFFSET_TEXELS 1.0
#endif
#ifndef FILTER_RADIUS_TEXELS
#define FILTER_RADIUS_TEXELS 1.5
#endif
#if FILTER == FILTER_PCF && !defined(PCF_KERNEL)
#error FILTER 1 (pcf) needs PCF_KERNEL
#endif
#if FILTER == FILTER_POISSON
#ifndef POISSON_SAMPLES
#error FILTER 2 (poisson) needs POISSON_SAMPLES
#endif
#include "common/sampling.glsl"
#endif

layout(binding = VISIBILITY_BINDING(0)) uniform sampler2DShadow shadowMap;

#define SHADOW_MAP_BINDING VISIBILITY_BINDING(1)
#define SHADOW_RECEIVER_BIAS RECEIVER_BIAS
#include "common/shadow_receiver.glsl"

float filteredVisibility(ShadowReceiver r, ivec2 pixel)
{
#if FILTER == FILTER_NONE
    return shadowCompareTap(shadowMap, r, vec2(0.0));
#elif FILTER == FILTER_PCF
    // Percentage-closer filtering (Reeves, Salesin, Cook 1987): the fraction of a box of
    // compares, one per texel, centred on the receiver.
    const int h = (PCF_KERNEL - 1) / 2;
    float lit = 0.0;
    for (int y = -h; y <= h; ++y)
        for (int x = -h; x <= h; ++x) lit += shadowCompareTap(shadowMap, r, vec2(x, y));
    return lit / float(PCF_KERNEL * PCF_KERNEL);
#elif FILTER == FILTER_POISSON
    mat2 rotation = poissonRotation(pixel);
    float lit = 0.0;
    for (int i = 0; i < POISSON_SAMPLES; ++i)
        lit += shadowCompareTap(shadowMap, r, rotation * kPoissonDisk[i] * FILTER_RADIUS_TEXELS);
    return lit / float(POISSON_SAMPLES);
#elif FILTER == FILTER_BILINEAR && RECEIVER_BIAS != SHADOW_RECEIVER_BIAS_PLANE
    // The sampler's LINEAR filter with compare: four compares weighted bilinearly in
    // hardware. A one-texel margin keeps the whole 2 x 2 footprint inside the face.
    return texture(shadowMap, vec3(shadowAtlasUv(r.face, shadowClampToFace(r.uv, 1.0)), r.depth));
#else
    // Bilinear with receiver plane bias: the same four texels and weights as the
    // hardware filter, but each compared against the plane's depth at its own centre.
    vec2 st = r.uv * shadowFaceTexels() - 0.5;
    vec2 f = st - floor(st);
    float t00 = shadowCompareTap(shadowMap, r, -f), t10 = shadowCompareTap(shadowMap, r, vec2(1.0, 0.0) - f);
    float t01 = shadowCompareTap(shadowMap, r, vec2(0.0, 1.0) - f), t11 = shadowCompareTap(shadowMap, r, vec2(1.0) - f);
    return mix(mix(t00, t10, f.x), mix(t01, t11, f.x), f.y);
#endif
}

// Straight-line: every pixel, in the map or not, runs the same code and the result is
// selected at the end (common/shadow_map.glsl: uniform loads).
float techniqueVisibility(ivec2 pixel, vec3 position, vec3 normal)
{
    ShadowReceiver r;
    bool inMap = makeShadowReceiver(pixel, position, NORMAL_OFFSET_TEXELS, r);
    float filtered = filteredVisibility(r, pixel);
    return shadowVisibilityAboveHorizon(inMap ? filtered : 1.0, position, normal);
}
