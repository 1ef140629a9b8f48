#version 460
// visibility::ReceiverMaskBuilder, step 2, for views whose technique compares with each receiver's
// own depth (engine/receiver_scatter.comp RECEIVER_DEPTH): every texel gets the least
// (farthest) receiver depth within `radius` texels, a square (a row pass, then a column
// pass), since a receiver's lookups read every texel within the technique's tap radius
// of its own and compare them all with the same depth.
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

int texel(int line, int i) { return pc.vertical != 0 ? i * pc.size + line : line * pc.size + i; }

void main()
{
    int line = int(gl_GlobalInvocationID.x);
    if (line >= pc.size) return;
    int width = 2 * pc.radius + 1;
    uint run = kNone;
    for (int i = 0; i < pc.size; ++i) {
        if (i % width == 0) run = kNone;
        run = min(run, depth[texel(line, i)]);
        prefix[texel(line, i)] = run;
    }
    // The prefix of the last block, for windows that end past the line.
    int lastBlock = (pc.size - 1) / width;
    uint lastPrefix = prefix[texel(line, pc.size - 1)];
    uint suffix = kNone;
    for (int k = pc.size - 1; k >= -pc.radius; --k) {
        if (k >= 0) {
            if (k % width == width - 1 || k == pc.size - 1) suffix = kNone;
            suffix = min(suffix, depth[texel(line, k)]);
        } else {
            suffix = kNone;  // before the line: the block holds no texel
        }
        int i = k + pc.radius;
        if (i >= pc.size) continue;
        int end = k + 2 * pc.radius;
        uint tail = end < pc.size ? prefix[texel(line, end)] : (end / width == lastBlock ? lastPrefix : kNone);
        depth[texel(line, i)] = min(suffix, tail);
    }
}
