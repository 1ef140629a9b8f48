#version 460
// render::ShadowMap, alpha-masked casters: texels below the material's cutoff cast no shadow.
#include "common/scene.glsl"

layout(location = 0) in vec2 inUv;
layout(location = 1) flat in uint inMaterial;

layout(std430, binding = 1) readonly buffer Materials { MaterialData materials[]; };
layout(binding = 2) uniform sampler2D baseColorTexture;

void main()
{
    MaterialData material = materials[inMaterial];
    if (material.baseColor.a * texture(baseColorTexture, inUv).a < material.alphaCutoff) discard;
}
