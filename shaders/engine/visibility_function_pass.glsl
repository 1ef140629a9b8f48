// The visibility pass around a technique's visibility function (plugin/VisibilityFunction.h):
// included after the function, it writes V_l for every pixel as the function gives it,
// VISIBILITY_NO_GEOMETRY where nothing was drawn. Shading's evaluation of the same
// function (engine/shading.glsl, fusedVisibility) must stay this expression.
#ifndef VISIBILITY_LOCAL_SIZE_X  // rows: measured 3-12% faster than 8 x 8 on llvmpipe
#define VISIBILITY_LOCAL_SIZE_X 64
#define VISIBILITY_LOCAL_SIZE_Y 1
#endif
layout(local_size_x = VISIBILITY_LOCAL_SIZE_X, local_size_y = VISIBILITY_LOCAL_SIZE_Y) in;

layout(binding = 3, VISIBILITY_FORMAT) uniform writeonly image2D visibilityOut;

// Straight-line: every pixel, seen or not, runs the same code and the result is selected
// at the end (common/shadow_map.glsl: uniform loads).
void main()
{
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(visibilityOut);
    bool inImage = all(lessThan(pixel, size));
    pixel = min(pixel, size - 1);

    vec4 position = gbufferPosition(pixel);
    float v = techniqueVisibility(pixel, position.xyz, gbufferNormal(pixel));
    v = position.w != 0.0 ? v : VISIBILITY_NO_GEOMETRY;
    if (inImage) imageStore(visibilityOut, pixel, vec4(sanitizeVisibility(v)));
}
