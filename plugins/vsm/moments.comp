#version 460
// The VSM family's first pass: every texel of render::ShadowMap's depth atlas becomes
// the stored values of its caster depth (moments.glsl warpDepth). Texels where nothing
// was drawn hold the far end of the scene's depth range (t = 1), behind every receiver.
#include "moments.glsl"

// vsm.cpp always defines it; compiled on its own: rg32f.
#ifndef MOMENT_FORMAT
#define MOMENT_FORMAT rg32f
#endif

layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 0) uniform sampler2D shadowDepth;
layout(binding = 1, MOMENT_FORMAT) uniform writeonly image2D momentsOut;

#define SHADOW_MAP_BINDING 2
#include "common/shadow_map.glsl"

layout(push_constant) uniform Push {
    vec2 exponents;  // moments.glsl warpDepth
} pc;

void main()
{
    // No early return: the texels past the image's edge compute a clamped texel and store
    // nothing (blur.comp says why).
    ivec2 size = imageSize(momentsOut);
    ivec2 texel = ivec2(gl_GlobalInvocationID.xy);
    bool inImage = all(lessThan(texel, size));
    texel = min(texel, size - 1);
    float t = shadowLinearDepth(shadowFaceOfTexel(texel), texelFetch(shadowDepth, texel, 0).r);
    vec4 warped = warpDepth(t, pc.exponents);
    if (inImage) imageStore(momentsOut, texel, warped);
}
