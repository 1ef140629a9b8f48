// The shading pass's body (engine/shading.comp is it on its own): shades every pixel
// from the G-buffer and each light's visibility V_l, the only place where shadows meet
// lighting (DESIGN.md). Lambertian surfaces, spot lights with inverse-square falloff, a
// small sky ambient, then the display transform. Included after common/gbuffer.glsl
// (GBUFFER_BINDING 0: gDepth, gNormal, GBufferCamera) and common/visibility.glsl, and
// after the visibility functions of the lights whose V shading evaluates.
#include "common/lambert.glsl"
#include "common/color.glsl"

// Compute, not a full-screen triangle into a colour attachment: on llvmpipe the fragment
// path writes a constant colour in half the time (4.4 against 9.3 ms), but this shading
// costs the same or more there (67.0 against 65.1 ms, medians of 5 rounds under load;
// docs/performance.md, "Full-screen passes"). A fragment shader loads every uniform value
// once per lane; a compute shader once per SIMD group where no lane can be masked, so
// main() is straight-line: no early return, the background selected at the end
// (docs/performance.md, "Uniform loads").
layout(local_size_x = 64, local_size_y = 1) in;  // rows: measured 3-12% faster than 8 x 8 on llvmpipe

layout(binding = 3) uniform sampler2D gAlbedo;
// The visibility images that shading reads (LIGHT_VISIBILITY_<i> below).
#if VISIBILITY_COUNT > 0
layout(binding = 4) uniform sampler2D visibility[VISIBILITY_COUNT];
#endif
layout(std430, binding = 5) readonly buffer Lights { LightData lights[]; };
layout(binding = 6, rgba8) uniform writeonly image2D outColor;

layout(push_constant) uniform Push {
    vec4 ambient;      // rgb sky irradiance / pi, w = exposure
    vec4 background;   // rgb colour where no geometry is seen
    ivec4 region;      // xy: the first pixel of this dispatch's rectangle, zw: its size
} pc;

// The pipeline is compiled for the frame's lights: LIGHT_COUNT (1..8), and for each light
// i LIGHT_VISIBILITY_<i>, how its V is had: 1.0 (no shadows), imageVisibility(k) (element
// k of visibility[]), or fusedVisibility(light<i>_techniqueVisibility(pixel, position.xyz,
// n), position) where shading evaluates the technique's visibility function itself
// (plugin/VisibilityFunction.h; the frame composes the function in before this file).
// Each image is read with a constant index: lavapipe has no dynamic indexing of sampler
// arrays, and a switch over the slots made llvmpipe fetch from all of them (13 ms of 32
// at 1280x720).
#define imageVisibility(SLOT) texelFetch(visibility[SLOT], pixel, 0).r
// What the light's visibility pass would have stored and shading read back: the same
// pixels whether or not the image exists (engine/visibility_function_pass.glsl).
// The function is called as an argument, for every pixel: in a branch (a ?: on the
// pixel's geometry) llvmpipe would load its every uniform value once per lane.
float fusedVisibility(float v, vec4 position)
{
    return visibilityAsStored(sanitizeVisibility(position.w != 0.0 ? v : VISIBILITY_NO_GEOMETRY));
}
#define ADD_LIGHT(I) radiance += lambertRadiance(lights[I], position.xyz, n, albedo, LIGHT_VISIBILITY_##I)
// LIGHT_SHADED_<i> 0 leaves light i out: the frame shades each rectangle of the screen
// with a pipeline for the lights that can reach it (frame/LightInfluence.h
// lightScreenRect), and a light adds exactly 0 beyond its spot cone, less than a display
// step beyond its range.
#ifndef LIGHT_VISIBILITY_0  // compiled on its own (a shader tool): every light unshadowed
#define LIGHT_VISIBILITY_0 1.0
#define LIGHT_VISIBILITY_1 1.0
#define LIGHT_VISIBILITY_2 1.0
#define LIGHT_VISIBILITY_3 1.0
#define LIGHT_VISIBILITY_4 1.0
#define LIGHT_VISIBILITY_5 1.0
#define LIGHT_VISIBILITY_6 1.0
#define LIGHT_VISIBILITY_7 1.0
#endif
#ifndef LIGHT_SHADED_0
#define LIGHT_SHADED_0 1
#define LIGHT_SHADED_1 1
#define LIGHT_SHADED_2 1
#define LIGHT_SHADED_3 1
#define LIGHT_SHADED_4 1
#define LIGHT_SHADED_5 1
#define LIGHT_SHADED_6 1
#define LIGHT_SHADED_7 1
#endif

void main()
{
    ivec2 local = ivec2(gl_GlobalInvocationID.xy);
    bool inside = all(lessThan(local, pc.region.zw));
    ivec2 pixel = pc.region.xy + min(local, pc.region.zw - 1);

    vec4 position = gbufferPosition(pixel);
    vec3 n = gbufferNormal(pixel);
    vec3 albedo = texelFetch(gAlbedo, pixel, 0).rgb;

    vec3 radiance = lambertSkyAmbient(albedo, n, pc.ambient.rgb);
#if LIGHT_SHADED_0
    ADD_LIGHT(0);
#endif
#if LIGHT_COUNT > 1 && LIGHT_SHADED_1
    ADD_LIGHT(1);
#endif
#if LIGHT_COUNT > 2 && LIGHT_SHADED_2
    ADD_LIGHT(2);
#endif
#if LIGHT_COUNT > 3 && LIGHT_SHADED_3
    ADD_LIGHT(3);
#endif
#if LIGHT_COUNT > 4 && LIGHT_SHADED_4
    ADD_LIGHT(4);
#endif
#if LIGHT_COUNT > 5 && LIGHT_SHADED_5
    ADD_LIGHT(5);
#endif
#if LIGHT_COUNT > 6 && LIGHT_SHADED_6
    ADD_LIGHT(6);
#endif
#if LIGHT_COUNT > 7 && LIGHT_SHADED_7
    ADD_LIGHT(7);
#endif
#if LIGHT_COUNT > 8
#error "shading.comp adds at most 8 lights (config::kMaxLights)"
#endif
    vec3 display = displayColor(radiance, pc.ambient.w);
    if (position.w == 0.0) display = linearToSrgb(pc.background.rgb);
    if (inside) imageStore(outColor, pixel, vec4(display, 1.0));
}
