#version 460
#include "common/scene.glsl"

layout(location = 0) in vec3 inPosition;
layout(location = 1) in vec3 inNormal;

layout(std430, binding = 0) readonly buffer Instances { InstanceData instances[]; };

layout(push_constant) uniform Push {
    mat4 viewProj;
} pc;

layout(location = 0) out vec3 outPositionWorld;
layout(location = 1) out vec3 outNormalWorld;
layout(location = 2) flat out vec4 outBaseColor;

void main()
{
    InstanceData inst = instances[gl_InstanceIndex];
    vec4 world = inst.model * vec4(inPosition, 1.0);
    outPositionWorld = world.xyz;
    outNormalWorld = mat3(inst.normalMatrix) * inNormal;
    outBaseColor = inst.baseColor;
    gl_Position = pc.viewProj * world;
}
