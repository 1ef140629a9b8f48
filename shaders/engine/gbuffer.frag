#version 460
#include "common/gbuffer.glsl"
#include "common/scene.glsl"

layout(location = 1) in vec3 inNormalWorld;
layout(location = 2) in vec2 inUv;
layout(location = 3) flat in vec4 inBaseColor;
layout(location = 4) flat in vec2 inAlphaTest;
// BASE_COLOR_TEXTURE 0: an untextured material's draws (frame/BaseColorPipelines.h).
#ifndef BASE_COLOR_TEXTURE
#define BASE_COLOR_TEXTURE 1
#endif
#if BASE_COLOR_TEXTURE
layout(binding = 2) uniform sampler2D baseColorTexture;  // pushed per group of draws
#endif

// The position is the depth's (common/gbuffer.glsl rebuilds it).
layout(location = 0) out vec2 outNormal;  // octahedral
layout(location = 1) out vec4 outAlbedo;

void main()
{
#if BASE_COLOR_TEXTURE
    vec4 baseColor = inBaseColor * texture(baseColorTexture, inUv);
#else
    vec4 baseColor = inBaseColor;
#endif
    // MASK: below the cutoff is a hole. BLEND is drawn as an opaque surface here (the
    // G-buffer holds one surface per pixel; translucency is the deep-shadow technique's).
    if (materialCutsHole(baseColor, inAlphaTest)) discard;
    vec3 n = normalize(inNormalWorld);
    // Two-sided lighting: a back face seen by the camera is lit from its visible side.
    if (!gl_FrontFacing) n = -n;
    outNormal = gbufferEncodeNormal(n);
    outAlbedo = baseColor;
}
