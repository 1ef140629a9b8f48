#version 460
// field(x, y) = values[y * width + x]^2: a storage buffer read into a storage image (the
// render graph executor's compute-chain test).
layout(local_size_x = 8, local_size_y = 8) in;
layout(std430, binding = 0) readonly buffer Values { float values[]; };
layout(binding = 1, r32f) uniform writeonly image2D field;
void main()
{
    ivec2 size = imageSize(field);
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, size))) return;
    float v = values[p.y * size.x + p.x];
    imageStore(field, p, vec4(v * v));
}
