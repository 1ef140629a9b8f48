#version 460
// The floor's forward draw (frame/FloorRenderer.h): one colour target, Lambert per light,
// and with SHADOWED one shadow-map compare per light (a nearest depth compare, the hard
// technique's default) - what a classic forward engine does per fragment, the least a
// frame that shades the same scene can cost.
#include "common/color.glsl"
#include "common/lambert.glsl"
#include "common/scene.glsl"

layout(location = 0) in vec3 inPositionWorld;
layout(location = 1) in vec3 inNormalWorld;
layout(location = 2) in vec2 inUv;
layout(location = 3) flat in vec4 inBaseColor;
layout(location = 4) flat in vec2 inAlphaTest;  // materialAlphaTest
// BASE_COLOR_TEXTURE 0: an untextured material's draws (frame/BaseColorPipelines.h).
#ifndef BASE_COLOR_TEXTURE
#define BASE_COLOR_TEXTURE 1
#endif
#if BASE_COLOR_TEXTURE
layout(binding = 2) uniform sampler2D baseColorTexture;  // pushed per group of draws
#endif
layout(std430, binding = 3) readonly buffer Lights { LightData lights[]; };

#if SHADOWED
layout(binding = 4) uniform sampler2DShadow shadowMaps[LIGHT_COUNT];
#define SHADOW_MAP_BINDING 5
#define SHADOW_MAP_ARRAY
#include "common/shadow_map.glsl"

layout(location = 5) in vec4 inShadowClip[LIGHT_COUNT];

// 1 lit, 0 shadowed; points outside the map are lit (as the hard technique calls them).
// The caller passes shadowMaps[I] with a constant I (ADD_LIGHT): lavapipe has no dynamic
// indexing of sampler arrays.
float shadowCompare(sampler2DShadow map, uint light, vec3 world)
{
    shadowMapIndex = light;
    vec3 uvDepth;
    if (shadowMapData.faceCount == 1u) {
        // The vertex shader's clip coordinates: one divide, one compare.
        vec4 clip = inShadowClip[light];
        if (!(clip.w > 0.0)) return 1.0;
        uvDepth = vec3(clip.xy / clip.w * 0.5 + 0.5, clip.z / clip.w);
        if (any(lessThan(uvDepth.xy, vec2(0.0))) || any(greaterThan(uvDepth.xy, vec2(1.0)))) return 1.0;
        return texture(map, uvDepth);
    }
    uint face = shadowFaceOf(world);
    float w;
    if (!shadowProject(face, world, uvDepth, w)) return 1.0;
    return texture(map, vec3(shadowAtlasUv(face, shadowClampToFace(uvDepth.xy, 0.5)), uvDepth.z));
}
#define VISIBILITY(I) shadowCompare(shadowMaps[I], I, inPositionWorld)
#else
#define VISIBILITY(I) 1.0
#endif

layout(push_constant) uniform Push {
    mat4 viewProj;
    vec4 ambient;     // rgb sky irradiance / pi, w = exposure
} pc;

layout(location = 0) out vec4 outColor;

#define ADD_LIGHT(I) radiance += lambertRadiance(lights[I], inPositionWorld, n, albedo, VISIBILITY(I))

void main()
{
#if BASE_COLOR_TEXTURE
    vec4 baseColor = inBaseColor * texture(baseColorTexture, inUv);
#else
    vec4 baseColor = inBaseColor;
#endif
    if (materialCutsHole(baseColor, inAlphaTest)) discard;
    vec3 n = normalize(inNormalWorld);
    if (!gl_FrontFacing) n = -n;  // two-sided, as the G-buffer
    vec3 albedo = baseColor.rgb;
    vec3 radiance = lambertSkyAmbient(albedo, n, pc.ambient.rgb);
    ADD_LIGHT(0);
#if LIGHT_COUNT > 1
    ADD_LIGHT(1);
#endif
#if LIGHT_COUNT > 2
    ADD_LIGHT(2);
#endif
#if LIGHT_COUNT > 3
    ADD_LIGHT(3);
#endif
#if LIGHT_COUNT > 4
    ADD_LIGHT(4);
#endif
#if LIGHT_COUNT > 5
    ADD_LIGHT(5);
#endif
#if LIGHT_COUNT > 6
    ADD_LIGHT(6);
#endif
#if LIGHT_COUNT > 7
    ADD_LIGHT(7);
#endif
#if LIGHT_COUNT > 8
#error "floor_forward.frag adds at most 8 lights (config::kMaxLights)"
#endif
    outColor = vec4(displayColor(radiance, pc.ambient.w), 1.0);
}
