#version 460
// The depth pass of render::ShadowMap (render/ShadowMap.h): casters from the light,
// reversed-Z (near = 1, far = 0).
// With ALPHA_MASK defined it also hands the fragment shader what it needs to cut holes;
#include "common/scene.glsl"

layout(location = 0) in vec3 inPosition;
#ifdef ALPHA_MASK
layout(location = 2) in vec2 inUv;
layout(location = 0) out vec2 outUv;
layout(location = 1) flat out uint outMaterial;
#endif

layout(std430, binding = 0) readonly buffer Instances { InstanceData instances[]; };

layout(push_constant) uniform Push {
    mat4 lightViewProj;
} pc;

void main()
{
    InstanceData inst = instances[gl_InstanceIndex];
#ifdef ALPHA_MASK
    outUv = inUv;
    outMaterial = inst.info.x;
#endif
    vec4 world = inst.model * vec4(inPosition, 1.0);
    gl_Position = pc.lightViewProj * world;
}
