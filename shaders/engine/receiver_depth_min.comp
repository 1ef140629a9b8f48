#version 460
// visibility::ReceiverMaskBuilder, step 2, for views whose technique compares with each receiver's
// own depth (engine/receiver_scatter.comp RECEIVER_DEPTH): every texel gets the least
// (farthest) receiver depth within `radius` texels, a square (a row pass, then a column
// pass), since a receiver's lookups read every texel within the technique's tap radius
// of its own and compare them all with the same depth.
//
// On a CPU device the host spreads instead (engine/src/visibility/ReceiverScatter.cpp).
//
// One invocation per row (or column), in place, with van Herk's and Gil and Werman's
// running minima over blocks of 2 radius + 1: three reads per texel whatever the radius
// (lavapipe runs serial sweeps far faster than shared-memory reductions). The forward
// sweep stores each texel's minimum from the start of its block (in `prefix`); the
// backward sweep keeps the minimum to the end of the block, and the window
// [k, k + 2 radius] is the suffix at k and the prefix at k + 2 radius, written to
// k + radius, which the backward sweep has already read.
layout(local_size_x = 64) in;

layout(std430, binding = 0) buffer Depth { uint depth[]; };    // in and out, row by row
layout(std430, binding = 1) buffer Prefix { uint prefix[]; };  // scratch, the same size

layout(push_constant) uniform Push {
    int size;      // texels per side
    int radius;    // texels, >= 1
    int vertical;  // 0: along rows, 1: along columns
} pc;

const uint kNone = 0xffffffffu;  // no receiver

int texel(bool vertical, int size, int line, int i) { return vertical ? i * size + line : line * size + i; }

void main()
{
    // The push constants are loaded before the first branch: on llvmpipe a uniform value
    // is loaded once per SIMD group only outside divergent control flow
    // (docs/performance.md, "Uniform loads").
    int size = pc.size, radius = pc.radius;
    bool vertical = pc.vertical != 0;
    int line = int(gl_GlobalInvocationID.x);
    if (line >= size) return;
    int width = 2 * radius + 1;
    uint run = kNone;
    for (int i = 0; i < size; ++i) {
        if (i % width == 0) run = kNone;
        run = min(run, depth[texel(vertical, size, line, i)]);
        prefix[texel(vertical, size, line, i)] = run;
    }
    // The prefix of the last block, for windows that end past the line.
    int lastBlock = (size - 1) / width;
    uint lastPrefix = prefix[texel(vertical, size, line, size - 1)];
    uint suffix = kNone;
    for (int k = size - 1; k >= -radius; --k) {
        if (k >= 0) {
            if (k % width == width - 1 || k == size - 1) suffix = kNone;
            suffix = min(suffix, depth[texel(vertical, size, line, k)]);
        } else {
            suffix = kNone;  // before the line: the block holds no texel
        }
        int i = k + radius;
        if (i >= size) continue;
        int end = k + 2 * radius;
        uint tail = end < size ? prefix[texel(vertical, size, line, end)] : (end / width == lastBlock ? lastPrefix : kNone);
        depth[texel(vertical, size, line, i)] = min(suffix, tail);
    }
}
