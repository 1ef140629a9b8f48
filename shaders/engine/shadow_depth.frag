#version 460
// The fragment shader of render::ShadowMap's depth passes, for the casters that need one:
//   ALPHA_MASK  alpha-masked casters: texels below the material's cutoff cast no shadow;
//   PEEL        a peeled layer (ShadowMap::addPeeledDepthPass; Everitt 2001): only what
//               lies behind the nearer layer's stored depth at the same texel is drawn,
//               so the depth test keeps the nearest surface behind it.
#include "common/scene.glsl"

#ifdef ALPHA_MASK
layout(location = 0) in vec2 inUv;
layout(location = 1) flat in uint inMaterial;

layout(std430, binding = 1) readonly buffer Materials { MaterialData materials[]; };
layout(binding = 2) uniform sampler2D baseColorTexture;
#endif

#ifdef PEEL
// The nearer layer: the same atlas, drawn with the same depth bias, so a fragment of the
// surface stored there is at least as near as its stored depth (reversed-Z: larger is
// nearer; the bias moved the stored depth away from the light) and is cut.
layout(binding = 3) uniform sampler2D nearerLayer;
#endif

void main()
{
#ifdef ALPHA_MASK
    MaterialData material = materials[inMaterial];
    if (material.baseColor.a * texture(baseColorTexture, inUv).a < material.alphaCutoff) discard;
#endif
#ifdef PEEL
    if (gl_FragCoord.z >= texelFetch(nearerLayer, ivec2(gl_FragCoord.xy), 0).r) discard;
#endif
}
