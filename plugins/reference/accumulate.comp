#version 460
// The rasterised reference (mode brute_force, RasterReference.h), one batch of light
// samples: every G-buffer point is compared with each sample's hard shadow map at its
// nearest texel, with receiver plane depth bias (common/shadow_receiver.glsl, as the
// hard plugin's bias_mode receiver_plane), and the lit compares are added to the sums
// of the batches before: x = sum of weight * lit, y = sum of weight.
//
// The batch's maps lie side by side in one depth image, a grid of gridColumns x
// gridRows atlases of the light's shape (render::ShadowMap's layout each); the map of
// sample k of the batch is cell (k % gridColumns, k / gridColumns).
//
// Weights: 1 for points of a rect or disk (uniform by area) and directions of the sun
// (uniform by solid angle): the measures the ray tracer averages over. A sphere light's
// samples are uniform by area over its whole surface, so each weighs the solid angle
// its piece of surface subtends at the receiver, cos(theta_s) / d^2, zero on the far
// side; their weighted mean is the fraction of the sphere's solid angle seen, as traced.
//
// The horizon: a sample below the receiver's tangent plane, dot(n, towards sample) <= 0
// with n the G-buffer normal (it faces the camera), counts as blocked, as in the ray
// tracer; a pixel without a normal has no horizon test.
#define GBUFFER_BINDING 6  // gDepth, gNormal, GBufferCamera: plugin::bindGBuffer
#include "common/gbuffer.glsl"
#include "common/visibility.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 2) uniform sampler2DShadow sampleMaps;
#ifndef FIRST_BATCH
layout(binding = 3, rg32f) uniform readonly image2D previousSums;  // the first batch starts from zero
#endif
layout(binding = 4, rg32f) uniform writeonly image2D sums;

#define SHADOW_MAP_BINDING 5
#define SHADOW_MAP_ARRAY
#define SHADOW_RECEIVER_BIAS 2
#include "common/shadow_receiver.glsl"

layout(push_constant) uniform Push {
    vec4 sphere;  // xyz centre, w radius of a sphere light; w = 0: every sample weighs 1
    uint firstSample;
    uint sampleCount;
    uint gridColumns;
    uint gridRows;
} pc;

// The solid angle weight of the current sample (shadowMapIndex) at receiver p.
float sampleWeight(vec3 p)
{
    if (!(pc.sphere.w > 0.0)) return 1.0;
    vec3 s = shadowMapData.light.xyz;
    vec3 outward = (s - pc.sphere.xyz) / pc.sphere.w;
    vec3 d = p - s;
    float distance2 = dot(d, d);
    if (!(distance2 > 0.0)) return 0.0;
    return max(dot(outward, d), 0.0) / (distance2 * sqrt(distance2));
}

// The nearest-texel compare of receiver r with map `k` of the batch: 1 lit, 0 shadowed.
float compareWithSampleMap(ShadowReceiver r, uint k)
{
    vec2 centre = shadowTapUv(r, vec2(0.0));
    vec2 cell = vec2(float(k % pc.gridColumns), float(k / pc.gridColumns));
    vec2 uv = (cell + shadowAtlasUv(r.face, centre)) / vec2(float(pc.gridColumns), float(pc.gridRows));
    return texture(sampleMaps, vec3(uv, shadowReferenceDepth(r, centre)));
}

void main()
{
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(pixel, imageSize(sums)))) return;

#ifdef FIRST_BATCH
    vec2 sum = vec2(0.0);
#else
    vec2 sum = imageLoad(previousSums, pixel).xy;
#endif
    vec4 position = gbufferPosition(pixel);
    if (position.w != 0.0) {
        vec3 p = position.xyz;
        vec3 n = gbufferNormal(pixel);
        for (uint k = 0u; k < pc.sampleCount; ++k) {
            shadowMapIndex = pc.firstSample + k;
            float weight = sampleWeight(p);
            if (!(weight > 0.0)) continue;
            vec3 l = shadowTowardsLight(p);
            float lit = 1.0;  // at the sample itself, or outside its map (a spot's cone): lit by contract
            if (dot(l, l) > 0.0 && dot(n, l) <= 0.0) {
                lit = 0.0;  // below the horizon
            } else {
                ShadowReceiver r;
                if (makeShadowReceiver(pixel, p, 0.0, r)) lit = compareWithSampleMap(r, k);
            }
            sum += vec2(weight * lit, weight);
        }
    }
    imageStore(sums, pixel, vec4(sum, 0.0, 0.0));
}
