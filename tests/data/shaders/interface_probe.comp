#version 460
// What reflection reads (gpu/ShaderInterface.h): one declaration of each kind a plugin
// binds, an array of samplers, a named and an anonymous buffer, and a binding the
// shader declares but never uses (a variant's leftover: it stays in the layout).
layout(local_size_x = 32, local_size_y = 2, local_size_z = 1) in;

layout(binding = 0, r32f) uniform writeonly image2D visibilityOut;
layout(binding = 2) uniform sampler2DShadow maps[3];
layout(std430, binding = 3) readonly buffer ShadowMapBuffer { vec4 light; } shadowMapBuffer;
layout(std430, binding = 4) readonly buffer Lights { vec4 lights[]; };
layout(std140, binding = 5) uniform Camera { mat4 viewProj; } camera;
layout(binding = 7) uniform sampler2D unusedHere;

void main()
{
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    float v = texture(maps[1], vec3(0.5, 0.5, shadowMapBuffer.light.w)) + lights[0].x + camera.viewProj[0][0];
    imageStore(visibilityOut, pixel, vec4(v));
}
