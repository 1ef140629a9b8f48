#version 460
// visibility::ReceiverMaskBuilder, step 2: dilates the receiver mask by `radius` texels (a square
// neighbourhood: a row pass, then a column pass), so that the casters a technique's
// lookups reach around a receiver's texel are kept. One invocation per row (or column)
// sweeps it forwards and backwards, keeping the distance to the nearest marked texel:
// linear in the size whatever the radius (lavapipe runs serial sweeps far faster than
// shared-memory reductions).
layout(local_size_x = 64) in;

layout(binding = 0, r8) uniform readonly image2D source;
layout(binding = 1, r8) uniform writeonly image2D target;

layout(push_constant) uniform Push {
    int size;      // texels per side
    int radius;    // dilation, in texels
    int vertical;  // 0: along rows, 1: along columns
} pc;

ivec2 texel(bool vertical, int line, int i) { return vertical ? ivec2(line, i) : ivec2(i, line); }

void main()
{
    // The push constants are loaded before the first branch: on llvmpipe a uniform value
    // is loaded once per SIMD group only outside divergent control flow
    // (docs/performance.md, "Uniform loads").
    int size = pc.size, radius = pc.radius;
    bool vertical = pc.vertical != 0;
    int line = int(gl_GlobalInvocationID.x);
    if (line >= size) return;
    const int kFar = 1 << 30;
    // Forward: distance to the nearest marked texel at or before i, stored as 0/1 at the
    // end; backward: the same from the other side, combined on the fly.
    int last = -kFar;
    for (int i = 0; i < size; ++i) {
        if (imageLoad(source, texel(vertical, line, i)).r >= 0.5) last = i;
        imageStore(target, texel(vertical, line, i), vec4(i - last <= radius ? 1.0 : 0.0));
    }
    int next = kFar;
    for (int i = size - 1; i >= 0; --i) {
        if (imageLoad(source, texel(vertical, line, i)).r >= 0.5) next = i;
        if (next - i <= radius) imageStore(target, texel(vertical, line, i), vec4(1.0));
    }
}
