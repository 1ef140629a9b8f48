#version 460
// The example's visibility pass: V_l for every pixel from one shadow-map comparison.
// The map and its conventions (one face or a cube atlas, reversed-Z) are the engine's
// render::ShadowMap, read through common/shadow_map.glsl; the receiver (the face its
// G-buffer position falls in, its uv and depth there) is common/shadow_receiver.glsl's.
#define GBUFFER_BINDING 0  // gDepth, gNormal, GBufferCamera: plugin::bindGBuffer
#include "common/gbuffer.glsl"
#include "common/visibility.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

// The C++ binds these by name (gpu::DescriptorPush); the numbers live here alone.
layout(binding = 3) uniform sampler2DShadow shadowMap;  // nearest, compareOp GREATER_OR_EQUAL
layout(binding = 4, VISIBILITY_FORMAT) uniform writeonly image2D visibilityOut;

// render::ShadowMap::buffer() ("shadowMapBuffer"). Constant and slope-scaled bias are
// the depth pass's rasterizer bias: no receiver-side bias here.
#define SHADOW_MAP_BINDING 5
#define SHADOW_RECEIVER_BIAS 0
#include "common/shadow_receiver.glsl"

void main()
{
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    // The last groups overhang the image: they compute a clamped pixel and store nothing.
    // No early return: on llvmpipe everything after one would load the buffers' uniform
    // values once per lane (common/shadow_map.glsl: uniform loads).
    ivec2 size = imageSize(visibilityOut);
    bool inImage = all(lessThan(pixel, size));
    pixel = min(pixel, size - 1);

    vec4 position = gbufferPosition(pixel);
    ShadowReceiver r;
    bool inMap = makeShadowReceiver(pixel, position.xyz, 0.0, r);
    // Reversed-Z: lit where the receiver is not farther from the light than the nearest
    // caster in its texel.
    float compare = shadowCompareTap(shadowMap, r, vec2(0.0));
    // Outside every face or behind the light the map has nothing to say: lit (the spot
    // cone in shading gives no light there anyway).
    // The contract (common/visibility.glsl): light from below the surface's tangent plane
    // is blocked by the surface itself; where the light straddles that plane the map's
    // word yields to the part above it (common/shadow_map.glsl).
    float v = shadowVisibilityAboveHorizon(inMap ? compare : 1.0, position.xyz, gbufferNormal(pixel));
    // Pixels that see no geometry hold 1.
    v = position.w != 0.0 ? v : VISIBILITY_NO_GEOMETRY;
    if (inImage) imageStore(visibilityOut, pixel, vec4(sanitizeVisibility(v)));
}
