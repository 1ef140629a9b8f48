#version 460
// The example's shadow-map pass: casters seen from the light, depth only, reversed-Z
// (near = 1, far = 0). The caster interface binds the scene's vertices and starts each
// draw at its instance's row of the instance table.
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
