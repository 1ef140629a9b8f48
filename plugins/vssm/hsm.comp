#version 460
// VSSM step L4 (paper Algorithm 1): one level >= 1 of the min-max hierarchical shadow
// map (hsm.glsl), from the level below it (level 0: the depth map).
layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 0) uniform sampler2D shadowDepth;

#define SHADOW_MAP_BINDING 2
#include "common/shadow_map.glsl"

float hsmLevel0(ivec2 texel) { return shadowLinearDepth(shadowFaceOfTexel(texel), texelFetch(shadowDepth, texel, 0).r); }

#define HSM_BINDING 1
#define HSM_QUALIFIER
#define HSM_WRITES
#include "hsm.glsl"

layout(push_constant) uniform Push {
    ivec2 size;  // the atlas (level 0), in texels
    int level;   // >= 1
} pc;

void main()
{
    // The push constants are loaded before the first branch, and the texels past the
    // level's edge compute a clamped texel and store nothing: on llvmpipe a uniform value
    // is loaded once per SIMD group only outside divergent control flow
    // (docs/performance.md, "Uniform loads").
    ivec2 size = pc.size;
    int level = pc.level;
    ivec2 levelSize = hsmLevelSize(size, level);
    ivec2 texel = ivec2(gl_GlobalInvocationID.xy);
    bool inLevel = all(lessThan(texel, levelSize));
    texel = min(texel, levelSize - 1);
    ivec2 a = texel * 2;
    vec2 v00 = hsmTexel(size, level - 1, a), v10 = hsmTexel(size, level - 1, a + ivec2(1, 0));
    vec2 v01 = hsmTexel(size, level - 1, a + ivec2(0, 1)), v11 = hsmTexel(size, level - 1, a + ivec2(1, 1));
    vec2 range = vec2(min(min(v00.x, v10.x), min(v01.x, v11.x)), max(max(v00.y, v10.y), max(v01.y, v11.y)));
    if (inLevel) imageStore(hsmImage, hsmLevelOrigin(size, level) + texel, vec4(range, 0.0, 0.0));
}
