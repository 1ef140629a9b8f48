#version 460
// The floor's forward draw (frame/FloorRenderer.h): the scene as a classic engine draws
// it, world position and normal handed to a fragment shader that lights and shadows it.
#include "common/scene.glsl"

layout(location = 0) in vec3 inPosition;
layout(location = 1) in vec3 inNormal;
layout(location = 2) in vec2 inUv;

layout(std430, binding = 0) readonly buffer Instances { InstanceData instances[]; };
layout(std430, binding = 1) readonly buffer Materials { MaterialData materials[]; };

layout(push_constant) uniform Push {
    mat4 viewProj;
    vec4 ambient;     // rgb sky irradiance / pi, w = exposure
} pc;

layout(location = 0) out vec3 outPositionWorld;
layout(location = 1) out vec3 outNormalWorld;
layout(location = 2) out vec2 outUv;
layout(location = 3) flat out vec4 outBaseColor;
layout(location = 4) flat out vec2 outAlphaTest;  // materialAlphaTest
#if SHADOWED
// As a classic engine's shadow texgen: each light's first face's clip coordinates per
// vertex, interpolated (projective: linear in clip space). A one-face map (spot,
// directional) needs nothing more per fragment; cube atlases pick their face there.
#define SHADOW_MAP_BINDING 5
#define SHADOW_MAP_ARRAY
#include "common/shadow_map.glsl"
layout(location = 5) out vec4 outShadowClip[LIGHT_COUNT];
#endif

void main()
{
    InstanceData inst = instances[gl_InstanceIndex];
    vec4 world = inst.model * vec4(inPosition, 1.0);
    outPositionWorld = world.xyz;
    outNormalWorld = mat3(inst.normalMatrix) * inNormal;
    outUv = inUv;
    MaterialData material = materials[inst.info.x];  // as the G-buffer's (gbuffer.vert)
    outBaseColor = material.baseColor;
    outAlphaTest = materialAlphaTest(material);
#if SHADOWED
    for (uint i = 0u; i < uint(LIGHT_COUNT); ++i) {
        shadowMapIndex = i;
        outShadowClip[i] = shadowMapData.faces[0].viewProj * world;
    }
#endif
    gl_Position = pc.viewProj * world;
}
