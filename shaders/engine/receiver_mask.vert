#version 460
// render::Visibility, step 2: the camera's visible receivers seen from the light.
#include "common/scene.glsl"

layout(location = 0) in vec3 inPosition;
layout(location = 0) out vec3 outWorld;

layout(std430, binding = 0) readonly buffer Instances { InstanceData instances[]; };

layout(push_constant) uniform Push {
    mat4 lightViewProj;
} pc;

void main()
{
    vec4 world = instances[gl_InstanceIndex].model * vec4(inPosition, 1.0);
    outWorld = world.xyz;
    gl_Position = pc.lightViewProj * world;
}
