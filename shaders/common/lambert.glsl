// Lambertian reflection of one light (light.glsl's LightData), as the engine shades:
// BRDF albedo / pi; directional lights give irradiance = intensity * cos, the others
// intensity / d^2 * cos, times the spot cone for spots and the emitter's own cosine for
// rect and disk lights (taken as their centre point here). `v` is the light's visibility.
// The frame's shading pass (engine/shading.comp) and the floor's forward pass
// (engine/floor_forward.frag) both shade with it.
#ifndef PENUMBRA_LAMBERT_GLSL
#define PENUMBRA_LAMBERT_GLSL

#include "common/light.glsl"

const float kLambertPi = 3.14159265;

vec3 lambertRadiance(LightData light, vec3 position, vec3 n, vec3 albedo, float v)
{
    uint type = lightType(light);
    if (type == LIGHT_DIRECTIONAL) {
        float cosTheta = max(dot(n, -light.direction.xyz), 0.0);
        return albedo / kLambertPi * light.radiance.rgb * (cosTheta * v);
    }
    vec3 toLight = light.positionWorld.xyz - position;
    // A surface point at the light's position must not divide by zero (FLT_MIN-sized
    // floor, far below any squared distance in a scene of any scale).
    float dist2 = max(dot(toLight, toLight), 1e-30);
    vec3 l = toLight * inversesqrt(dist2);
    float falloff = max(dot(n, l), 0.0) * v / dist2;
    if (type == LIGHT_SPOT) falloff *= spotFactor(light, -toLight);
    if (type == LIGHT_RECT || type == LIGHT_DISK) falloff *= max(dot(light.direction.xyz, -l), 0.0);
    return albedo / kLambertPi * light.radiance.rgb * falloff;
}

// The sky's ambient light reflected by a surface of normal n: hemispherical, brighter for
// up-facing surfaces, never zero. `skyAmbient` is the sky irradiance / pi.
vec3 lambertSkyAmbient(vec3 albedo, vec3 n, vec3 skyAmbient)
{
    return albedo * skyAmbient * (0.6 + 0.4 * n.y);
}

#endif
