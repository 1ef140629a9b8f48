#version 460
// Depth-only shadow-map pass: casters from the light, reversed-Z (near = 1, far = 0).
#include "common/scene.glsl"

layout(location = 0) in vec3 inPosition;

layout(std430, binding = 0) readonly buffer Instances { InstanceData instances[]; };

layout(push_constant) uniform Push {
    mat4 lightViewProj;
} pc;

void main()
{
    gl_Position = pc.lightViewProj * (instances[gl_InstanceIndex].model * vec4(inPosition, 1.0));
}
