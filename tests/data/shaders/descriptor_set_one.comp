#version 460
// A resource outside descriptor set 0: Penumbra's pipelines have one push-descriptor set.
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 1, binding = 0, r32f) uniform writeonly image2D visibilityOut;
void main() { imageStore(visibilityOut, ivec2(gl_GlobalInvocationID.xy), vec4(1.0)); }
