#version 460
// The deep shadow map's neighbour links (§1.3.3), one invocation per texel of the atlas:
// each node of the texel's sorted list gets the depth-nearest node of the list at
// texel + (1, 0) (`right`) and at texel + (0, 1) (`upper`). Both lists run from the light
// outwards, so one forward walk of each neighbour list serves the whole list (a merge).
// A neighbour outside the texel's face (the last column or row of a face, or of the
// atlas: the next cell is another cube face) or with an empty list links to kDeepNone,
// and a lookup starts that list from its head.
#define DEEP_NODES_BINDING 2
#define DEEP_NODES_WRITE
#include "deep_lists.glsl"

layout(local_size_x = 64, local_size_y = 1) in;

layout(binding = 0, r32ui) uniform readonly uimage2D heads;
layout(binding = 1, r32ui) uniform readonly uimage2D lengths;  // sort.comp's

layout(push_constant) uniform Push {
    uint faceTexels;  // texels per face side: links stay in the face's cell
} pc;

// The head of the neighbour's list, kDeepNone outside the face or when it is empty.
uint neighbourHead(ivec2 texel, ivec2 step)
{
    ivec2 other = texel + step;
    bool sameFace = all(equal(uvec2(texel) / pc.faceTexels, uvec2(other) / pc.faceTexels));
    if (!sameFace || any(greaterThanEqual(other, imageSize(heads)))) return kDeepNone;
    return (imageLoad(lengths, other).r & 0xFFFFu) == 0u ? kDeepNone : imageLoad(heads, other).r;
}

// The node of the list walked by `q` nearest in depth to `depth`; q moves forward and is
// where the next (farther) node's search resumes.
uint nearestNode(inout uint q, float depth)
{
    if (q == kDeepNone) return kDeepNone;
    for (int i = 0; i < DEEP_SORT_CAPACITY; ++i) {
        uint next = nodes[q].next;
        if (next == kDeepNone || nodes[next].depth < depth) break;  // next is farther
        q = next;
    }
    uint next = nodes[q].next;
    bool nextCloser = next != kDeepNone && abs(nodes[next].depth - depth) < abs(nodes[q].depth - depth);
    return nextCloser ? next : q;
}

void main()
{
    ivec2 texel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(texel, imageSize(heads)))) return;
    uint kept = imageLoad(lengths, texel).r & 0xFFFFu;
    if (kept == 0u) return;
    uint right = neighbourHead(texel, ivec2(1, 0)), upper = neighbourHead(texel, ivec2(0, 1));
    uint node = imageLoad(heads, texel).r;
    for (uint k = 0u; k < kept; ++k) {
        float d = nodes[node].depth;
        nodes[node].right = nearestNode(right, d);
        nodes[node].upper = nearestNode(upper, d);
        node = nodes[node].next;
    }
}
