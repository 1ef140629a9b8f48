// Lights as the shading pass reads them (one std430 array, filled by
// frame/FrameRenderer.cpp). Type codes match scene::LightType.
#ifndef PENUMBRA_LIGHT_GLSL
#define PENUMBRA_LIGHT_GLSL

#define LIGHT_DIRECTIONAL 0u
#define LIGHT_SPOT 1u
#define LIGHT_POINT 2u
#define LIGHT_RECT 3u
#define LIGHT_DISK 4u

struct LightData {
    vec4 positionWorld;   // xyz centre, w = type code
    vec4 direction;       // xyz unit axis (directional: travel direction), w = cos(outer half-angle)
    vec4 radiance;        // rgb colour * intensity, w = cos(inner half-angle)
};

uint lightType(LightData light) { return uint(light.positionWorld.w + 0.5); }

// Smooth spot falloff between the inner and outer cones; 0 outside the outer cone.
float spotFactor(LightData light, vec3 toSurface)
{
    float cosAngle = dot(normalize(toSurface), light.direction.xyz);
    float cosOuter = light.direction.w;
    float cosInner = light.radiance.w;
    return smoothstep(cosOuter, max(cosInner, cosOuter + 1e-4), cosAngle);
}

#endif
