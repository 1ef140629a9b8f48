// Display transform: exposure, a filmic curve, then the sRGB transfer function (the PNG is
// sRGB; storage images cannot be sRGB, so the encode happens here).
#ifndef PENUMBRA_COLOR_GLSL
#define PENUMBRA_COLOR_GLSL

// Narkowicz's ACES fit: maps [0, inf) to [0, 1).
vec3 tonemapAces(vec3 x)
{
    const float a = 2.51, b = 0.03, c = 2.43, d = 0.59, e = 0.14;
    return clamp((x * (a * x + b)) / (x * (c * x + d) + e), 0.0, 1.0);
}

vec3 linearToSrgb(vec3 c)
{
    c = clamp(c, 0.0, 1.0);
    return mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), c));
}

// Reflected radiance to the displayed sRGB colour. The tone curve saturates long before
// 1e4; the clamp keeps x*x inside fp32 so that a huge irradiance maps to white instead of
// inf/inf = NaN.
vec3 displayColor(vec3 radiance, float exposure)
{
    return linearToSrgb(tonemapAces(min(radiance * exposure, vec3(1e4))));
}

#endif
