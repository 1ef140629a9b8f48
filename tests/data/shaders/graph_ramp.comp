#version 460
// values[i] = values[i] * scale + i: one storage buffer read and written in place (the
// render graph executor's compute-chain test).
layout(local_size_x = 64) in;
layout(std430, binding = 0) buffer Values { float values[]; };
layout(push_constant) uniform Push {
    float scale;
    uint count;
};
void main()
{
    uint i = gl_GlobalInvocationID.x;
    if (i >= count) return;
    values[i] = values[i] * scale + float(i);
}
