// Percentage-closer soft shadows (Fernando 2005) for one light, per G-buffer pixel, as its
// visibility function (plugin/VisibilityFunction.h):
//   1. blocker search: blocker_samples depth taps on a rotated Poisson disk over the
//      region of the map that the light covers as seen from the receiver; the texels
//      nearer the light than the receiver are blockers, their mean distance d_b;
//   2. penumbra estimate: w = (d_r - d_b) w_light / d_b (Fernando eq. 1, similar
//      triangles between the light, the blocker and the receiver);
//   3. filter: filter_samples compares on the same disk scaled to w / 2, their mean V_l.
// Radii are in texels and clamped to max_search_radius / max_filter_radius; no blocker
// gives V = 1, light size 0 the hard shadow's single compare.
//
// The map is render::ShadowMap's (shaders/common/shadow_map.glsl), reversed-Z: a texel is
// a blocker where its depth is larger than the receiver's reference depth. With
// RECEIVER_BIAS 2 (receiver plane, shaders/common/shadow_receiver.glsl) every tap of the
// search and the filter compares against the receiver's plane at that tap, so a tilted
// receiver neither finds itself as a blocker nor shadows itself under a wide filter;
// with 0 the rasterizer's slope bias is all there is.
#include "common/sampling.glsl"

// The plugin always defines them (pcss.cpp); compiled on its own this is the default.
#ifndef RECEIVER_BIAS
#define RECEIVER_BIAS 2
#endif
#ifndef BLOCKER_SAMPLES
#define BLOCKER_SAMPLES 16
#define FILTER_SAMPLES 16
#define MAX_SEARCH_TEXELS 32.0
#define MAX_FILTER_TEXELS 32.0
#endif

layout(binding = VISIBILITY_BINDING(0)) uniform sampler2DShadow shadowCompare;
layout(binding = VISIBILITY_BINDING(1)) uniform sampler2D shadowDepth;  // the same map, raw depths
// What follows the light (pcss.cpp PcssLight): lights at a position: w_light in world
// units; directional lights: the penumbra width per unit of receiver-blocker distance,
// 2 tan(angular diameter / 2).
// ownShape: 1 where the size is the light's own (a rect or disk light's shape then shapes
// the kernels: common/penumbra_estimate.glsl shadowLightExtent), 0 for the light_size
// parameter's square.
layout(std140, binding = VISIBILITY_BINDING(2)) uniform PcssLight {
    float lightSize;
    float ownShape;
} pcssLight;

#define SHADOW_MAP_BINDING VISIBILITY_BINDING(3)
#define SHADOW_RECEIVER_BIAS RECEIVER_BIAS
#include "common/shadow_receiver.glsl"
#include "common/penumbra_estimate.glsl"

// Step 1: the mean distance of the blockers among `samples` search taps; false when
// there is none (the receiver sees the whole light). `range`: the face's depthRange.
bool averageBlockerDistance(ShadowReceiver r, vec4 range, mat2 rotation, vec2 radiusTexels, uint samples,
                            out float dBlocker)
{
    float sum = 0.0;
    uint count = 0u;
    for (uint i = 0u; i < samples; ++i) {
        vec2 uv = shadowTapUv(r, (rotation * kPoissonDisk[i]) * radiusTexels);
        float depth = textureLod(shadowDepth, shadowAtlasUv(r.face, uv), 0.0).r;
        // The exact negation of the compare sampler's "lit": reference >= depth.
        bool blocker = depth > shadowReferenceDepth(r, uv);
        float distance = shadowDistanceInRange(range, depth);
        sum += blocker ? distance : 0.0;
        count += blocker ? 1u : 0u;
    }
    dBlocker = count > 0u ? sum / float(count) : 0.0;
    return count > 0u;
}

// Branch-free outside its loops, and the light's size and the face are loaded before
// them (common/shadow_map.glsl: uniform loads): every case is computed and selected.
float pcssVisibility(ShadowReceiver r, ivec2 pixel, vec3 position)
{
    ShadowFace face = shadowMapData.faces[r.face];
    float lightSize = pcssLight.lightSize;
    vec2 lightExtent = shadowLightExtent(face, position, lightSize, pcssLight.ownShape > 0.5);
    float maxSearchTexels = MAX_SEARCH_TEXELS;
    float maxFilterTexels = MAX_FILTER_TEXELS;
    uint blockerSamples = clamp(uint(BLOCKER_SAMPLES), 1u, uint(kPoissonDisk.length()));
    uint filterSamples = clamp(uint(FILTER_SAMPLES), 1u, uint(kPoissonDisk.length()));

    float dReceiver = shadowDistanceInRange(face.depthRange, r.depth);
    mat2 rotation = poissonRotation(pixel);
    float dBlocker;
    vec2 search = shadowSearchRadiusTexels(face, lightExtent, dReceiver, maxSearchTexels);
    bool blocked = averageBlockerDistance(r, face.depthRange, rotation, search, blockerSamples, dBlocker);

    vec2 radius = shadowFilterRadiusTexels(face, lightExtent, dReceiver, dBlocker, maxFilterTexels);
    float lit = 0.0;
    for (uint i = 0u; i < filterSamples; ++i) lit += shadowCompareTap(shadowCompare, r, (rotation * kPoissonDisk[i]) * radius);
    float soft = blocked ? lit / float(filterSamples) : 1.0;  // no blocker: the whole light
    // A light of size 0 (or a degenerate map) casts a hard shadow: exactly hard's one
    // nearest compare.
    float hard = shadowCompareTap(shadowCompare, r, vec2(0.0));
    return lightSize > 0.0 && face.texel.x > 0.0 ? soft : hard;
}

// Straight-line up to the technique's own search and filter: every pixel runs the same
// code and the results are selected at the end (common/shadow_map.glsl: uniform loads).
float techniqueVisibility(ivec2 pixel, vec3 position, vec3 normal)
{
    ShadowReceiver r;
    bool inMap = makeShadowReceiver(pixel, position, 0.0, r);
    float pcss = pcssVisibility(r, pixel, position);
    return shadowVisibilityAboveHorizon(inMap ? pcss : 1.0, position, normal);
}
