#version 460
#include "common/scene.glsl"

layout(location = 0) in vec3 inPosition;
layout(location = 1) in vec3 inNormal;
layout(location = 2) in vec2 inUv;

layout(std430, binding = 0) readonly buffer Instances { InstanceData instances[]; };
layout(std430, binding = 1) readonly buffer Materials { MaterialData materials[]; };

layout(push_constant) uniform Push {
    mat4 viewProj;
} pc;

layout(location = 1) out vec3 outNormalWorld;
layout(location = 2) out vec2 outUv;
layout(location = 3) flat out vec4 outBaseColor;
layout(location = 4) flat out vec2 outAlphaTest;  // materialAlphaTest

void main()
{
    InstanceData inst = instances[gl_InstanceIndex];
    vec4 world = inst.model * vec4(inPosition, 1.0);
    outNormalWorld = mat3(inst.normalMatrix) * inNormal;
    outUv = inUv;
    MaterialData material = materials[inst.info.x];
    outBaseColor = material.baseColor;
    outAlphaTest = materialAlphaTest(material);
    gl_Position = pc.viewProj * world;
}
