#version 460
// Percentage-closer soft shadows (Fernando 2005) for one light, per G-buffer pixel:
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
#define GBUFFER_BINDING 6  // gDepth, gNormal, GBufferCamera: plugin::bindGBuffer
#include "common/gbuffer.glsl"
#include "common/sampling.glsl"
#include "common/visibility.glsl"

// The plugin always defines it (pcss.cpp); compiled on its own this is the default.
#ifndef RECEIVER_BIAS
#define RECEIVER_BIAS 2
#endif

layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 1) uniform sampler2DShadow shadowCompare;
layout(binding = 2, VISIBILITY_FORMAT) uniform writeonly image2D visibilityOut;
layout(binding = 5) uniform sampler2D shadowDepth;  // the same map, raw depths

#define SHADOW_MAP_BINDING 3
#define SHADOW_RECEIVER_BIAS RECEIVER_BIAS
#include "common/shadow_receiver.glsl"
#include "common/penumbra_estimate.glsl"

layout(push_constant) uniform Push {
    // Lights at a position: w_light in world units. Directional lights: the penumbra
    // width per unit of receiver-blocker distance, 2 tan(angular diameter / 2).
    float lightSize;
    float maxSearchTexels;
    float maxFilterTexels;
    uint blockerSamples;
    uint filterSamples;
} pc;

// Step 1: the mean distance of the blockers among the search taps; false when there is
// none (the receiver sees the whole light).
bool averageBlockerDistance(ShadowReceiver r, mat2 rotation, float radiusTexels, out float dBlocker)
{
    float sum = 0.0;
    uint count = 0u;
    uint samples = clamp(pc.blockerSamples, 1u, uint(kPoissonDisk.length()));
    for (uint i = 0u; i < samples; ++i) {
        vec2 uv = shadowTapUv(r, rotation * kPoissonDisk[i] * radiusTexels);
        float depth = textureLod(shadowDepth, shadowAtlasUv(r.face, uv), 0.0).r;
        // The exact negation of the compare sampler's "lit": reference >= depth.
        if (depth > shadowReferenceDepth(r, uv)) {
            sum += shadowDistance(r.face, depth);
            ++count;
        }
    }
    dBlocker = count > 0u ? sum / float(count) : 0.0;
    return count > 0u;
}

float pcssVisibility(ShadowReceiver r, ivec2 pixel)
{
    ShadowFace face = shadowMapData.faces[r.face];
    // A light of size 0 (or a degenerate map) casts a hard shadow: exactly hard's one
    // nearest compare.
    if (!(pc.lightSize > 0.0) || !(face.texel.x > 0.0)) return shadowCompareTap(shadowCompare, r, vec2(0.0));

    float dReceiver = shadowDistance(r.face, r.depth);
    mat2 rotation = poissonRotation(pixel);
    float dBlocker;
    float search = shadowSearchRadiusTexels(face, pc.lightSize, dReceiver, pc.maxSearchTexels);
    if (!averageBlockerDistance(r, rotation, search, dBlocker)) return 1.0;

    float radius = shadowFilterRadiusTexels(face, pc.lightSize, dReceiver, dBlocker, pc.maxFilterTexels);
    uint samples = clamp(pc.filterSamples, 1u, uint(kPoissonDisk.length()));
    float lit = 0.0;
    for (uint i = 0u; i < samples; ++i) lit += shadowCompareTap(shadowCompare, r, rotation * kPoissonDisk[i] * radius);
    return lit / float(samples);
}

void main()
{
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(pixel, imageSize(visibilityOut)))) return;

    vec4 position = gbufferPosition(pixel);
    float v = VISIBILITY_NO_GEOMETRY;
    ShadowReceiver r;
    if (position.w != 0.0) {
        if (makeShadowReceiver(pixel, position.xyz, 0.0, r)) v = pcssVisibility(r, pixel);
        v *= shadowLightAboveHorizon(position.xyz, gbufferNormal(pixel));
    }
    imageStore(visibilityOut, pixel, vec4(sanitizeVisibility(v)));
}
