#version 460
// The example's visibility pass: V_l for every pixel from one shadow-map comparison.
// Each pixel's world position (G-buffer) goes into the light's clip space; the sampler
// compares its depth with the nearest texel (compareOp GREATER_OR_EQUAL: reversed-Z, so
// the surface is lit when it is not farther from the light than the biased caster).
#include "common/gbuffer.glsl"
#include "common/visibility.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 0, GBUFFER_POSITION_FORMAT) uniform readonly image2D gPosition;
layout(binding = 1) uniform sampler2DShadow shadowMap;
layout(binding = 2, VISIBILITY_FORMAT) uniform writeonly image2D visibilityOut;
layout(binding = 3, GBUFFER_NORMAL_FORMAT) uniform readonly image2D gNormal;

layout(push_constant) uniform Push {
    mat4 lightViewProj;
    vec4 towardsLight;  // xyz position (w = 1) or direction towards the light (w = 0)
} pc;

void main()
{
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(pixel, imageSize(visibilityOut)))) return;

    vec4 position = imageLoad(gPosition, pixel);
    float v = VISIBILITY_NO_GEOMETRY;
    if (position.w != 0.0) {
        vec4 clip = pc.lightViewProj * vec4(position.xyz, 1.0);
        // Behind the light or outside the map, the map has nothing to say: V = 1 (the spot
        // cone in shading gives no light there anyway).
        if (clip.w > 0.0) {
            vec3 ndc = clip.xyz / clip.w;
            vec2 uv = ndc.xy * 0.5 + 0.5;
            if (all(greaterThanEqual(uv, vec2(0.0))) && all(lessThanEqual(uv, vec2(1.0)))) {
                v = texture(shadowMap, vec3(uv, ndc.z));
            }
        }
        // The contract (common/visibility.glsl): light from below the surface's tangent
        // plane is blocked by the surface itself. This example's light is a point.
        vec3 n = imageLoad(gNormal, pixel).xyz;
        vec3 l = pc.towardsLight.w > 0.0 ? pc.towardsLight.xyz - position.xyz : pc.towardsLight.xyz;
        if (dot(n, n) > 0.0 && !(dot(n, l) > 0.0)) v = 0.0;
    }
    imageStore(visibilityOut, pixel, vec4(sanitizeVisibility(v)));
}
