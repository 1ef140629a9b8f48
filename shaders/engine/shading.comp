#version 460
// Shades every pixel from the G-buffer and each light's visibility image V_l: the only
// place where shadows meet lighting (DESIGN.md). Lambertian surfaces, spot lights with
// inverse-square falloff, a small sky ambient, then the display transform.
#include "common/gbuffer.glsl"
#include "common/light.glsl"
#include "common/color.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 0, GBUFFER_POSITION_FORMAT) uniform readonly image2D gPosition;
layout(binding = 1, GBUFFER_NORMAL_FORMAT) uniform readonly image2D gNormal;
layout(binding = 2, GBUFFER_ALBEDO_FORMAT) uniform readonly image2D gAlbedo;
layout(binding = 3) uniform sampler2D visibility[MAX_LIGHTS];
layout(std430, binding = 4) readonly buffer Lights { LightData lights[]; };
layout(binding = 5, rgba8) uniform writeonly image2D outColor;

// lavapipe has no dynamic indexing of sampler arrays (not even dynamically uniform), so
// each slot is read with a constant index.
#if MAX_LIGHTS != 8
#error "lightVisibility() reads exactly 8 slots: update it together with MAX_LIGHTS"
#endif
float lightVisibility(uint light, ivec2 pixel)
{
    switch (light) {
    case 0u: return texelFetch(visibility[0], pixel, 0).r;
    case 1u: return texelFetch(visibility[1], pixel, 0).r;
    case 2u: return texelFetch(visibility[2], pixel, 0).r;
    case 3u: return texelFetch(visibility[3], pixel, 0).r;
    case 4u: return texelFetch(visibility[4], pixel, 0).r;
    case 5u: return texelFetch(visibility[5], pixel, 0).r;
    case 6u: return texelFetch(visibility[6], pixel, 0).r;
    case 7u: return texelFetch(visibility[7], pixel, 0).r;
    }
    return 1.0;
}

layout(push_constant) uniform Push {
    vec4 ambient;      // rgb sky irradiance / pi, w = exposure
    vec4 background;   // rgb colour where no geometry is seen
    uint lightCount;
} pc;

void main()
{
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(outColor);
    if (any(greaterThanEqual(pixel, size))) return;

    vec4 position = imageLoad(gPosition, pixel);
    if (position.w == 0.0) {
        imageStore(outColor, pixel, vec4(linearToSrgb(pc.background.rgb), 1.0));
        return;
    }
    vec3 n = normalize(imageLoad(gNormal, pixel).xyz);
    vec3 albedo = imageLoad(gAlbedo, pixel).rgb;

    // Hemispherical ambient: brighter for up-facing surfaces, never zero.
    vec3 radiance = albedo * pc.ambient.rgb * (0.6 + 0.4 * n.y);
    const float kPi = 3.14159265;
    for (uint i = 0u; i < pc.lightCount; ++i) {
        LightData light = lights[i];
        vec3 toLight = light.positionWorld.xyz - position.xyz;
        // Guard: a surface point at the light's position must not divide by zero. The
        // floor is FLT_MIN-sized, far below any squared distance in a scene of any scale;
        // the irradiance it can produce is bounded by the clamp before tone mapping.
        float dist2 = max(dot(toLight, toLight), 1e-30);
        vec3 l = toLight * inversesqrt(dist2);
        float cosTheta = max(dot(n, l), 0.0);
        float spot = spotFactor(light, -toLight);
        float v = lightVisibility(i, pixel);
        radiance += albedo / kPi * light.radiance.rgb * (cosTheta * spot * v / dist2);
    }
    // The tone curve saturates long before 1e4; the clamp keeps x*x inside fp32 so that
    // a huge irradiance maps to white instead of inf/inf = NaN.
    vec3 color = linearToSrgb(tonemapAces(min(radiance * pc.ambient.w, vec3(1e4))));
    imageStore(outColor, pixel, vec4(color, 1.0));
}
