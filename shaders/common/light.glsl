// Lights as the shading pass reads them (one std430 array, filled by render/FrameRenderer.cpp).
#ifndef PENUMBRA_LIGHT_GLSL
#define PENUMBRA_LIGHT_GLSL

struct LightData {
    vec4 positionWorld;   // xyz, w unused
    vec4 direction;       // xyz unit spot axis, w = cos(outer half-angle)
    vec4 radiance;        // rgb colour * intensity (W/sr), w = cos(inner half-angle)
};

// Smooth spot falloff between the inner and outer cones; 0 outside the outer cone.
float spotFactor(LightData light, vec3 toSurface)
{
    float cosAngle = dot(normalize(toSurface), light.direction.xyz);
    float cosOuter = light.direction.w;
    float cosInner = light.radiance.w;
    return smoothstep(cosOuter, max(cosInner, cosOuter + 1e-4), cosAngle);
}

#endif
