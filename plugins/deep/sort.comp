#version 460
// The deep shadow map's sort pass (§1.3.2), one invocation per texel of the atlas: the
// texel's list is read into a local array, insertion-sorted from the light outwards,
// turned into transmittances (eq. 1.1: the product of (1 - alpha) over a node and all
// nearer ones), truncated, and written back into the list's own nodes with `prev` links.
//
// Truncation: the list ends at the first node whose transmittance is at most `epsilon`.
// Whatever lies behind it can only lower the light further, from at most epsilon to no
// less than 0, so a lookup behind the cut is off by at most epsilon: the bound holds for
// every depth. The paper cuts where one more node changes the transmittance by less than
// epsilon (prod_{k+1} > prod_k - epsilon), which gives no bound: a faint fragment
// (alpha 0.001) in front of an opaque wall would drop the wall. For lists of equal alphas
// (hair) the two cut at about the same node. Behind a transmittance of 0 (an opaque
// fragment) the cut is exact, whatever epsilon.
//
// A list longer than DEEP_SORT_CAPACITY keeps its DEEP_SORT_CAPACITY nearest fragments;
// the rest are counted (counters.overSortCap).
#define DEEP_NODES_BINDING 2
#define DEEP_NODES_WRITE
#include "deep_lists.glsl"
#define DEEP_COUNTERS_BINDING 3
#include "deep_counters.glsl"

layout(local_size_x = 64, local_size_y = 1) in;

layout(binding = 0, r32ui) uniform readonly uimage2D heads;
// Per texel: the fragments that reached it (depth complexity, at most 65535) << 16 | the
// nodes kept after truncation.
layout(binding = 1, r32ui) uniform writeonly uimage2D lengths;

layout(push_constant) uniform Push {
    float epsilon;
    uint capacity;  // the pool's nodes: no list holds more
} pc;

void main()
{
    ivec2 texel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(texel, imageSize(heads)))) return;
    uint head = imageLoad(heads, texel).r;

    // Insertion sort, nearest first (reversed-Z: largest depth first), keeping the
    // DEEP_SORT_CAPACITY nearest.
    float depth[DEEP_SORT_CAPACITY];
    float alpha[DEEP_SORT_CAPACITY];
    uint n = 0u, total = 0u;
    for (uint i = head; i != kDeepNone && total < pc.capacity; i = nodes[i].next) {
        ++total;
        float d = nodes[i].depth, a = nodes[i].transmittance;
        if (n == uint(DEEP_SORT_CAPACITY)) {
            if (!(d > depth[n - 1u])) continue;  // farther than every kept one
            --n;                                 // the farthest kept one gives way
        }
        uint j = n;
        for (; j > 0u && depth[j - 1u] < d; --j) {
            depth[j] = depth[j - 1u];
            alpha[j] = alpha[j - 1u];
        }
        depth[j] = d;
        alpha[j] = a;
        ++n;
    }

    float tau = 1.0;
    uint kept = 0u;
    for (uint k = 0u; k < n; ++k) {
        tau *= 1.0 - alpha[k];
        alpha[k] = tau;
        kept = k + 1u;
        if (tau <= pc.epsilon) break;
    }

    // Back into the list's own nodes, in order; the nodes past the cut leave the list.
    uint node = head, prev = kDeepNone;
    for (uint k = 0u; k < kept; ++k) {
        uint next = nodes[node].next;
        nodes[node].depth = depth[k];
        nodes[node].transmittance = alpha[k];
        nodes[node].prev = prev;
        nodes[node].next = k + 1u < kept ? next : kDeepNone;
        nodes[node].right = kDeepNone;
        nodes[node].upper = kDeepNone;
        prev = node;
        node = next;
    }

    imageStore(lengths, texel, uvec4((min(total, 65535u) << 16) | kept));
    if (total == 0u) return;
    atomicAdd(counters.kept, kept);
    atomicMax(counters.longest, total);
    if (total > n) atomicAdd(counters.overSortCap, total - n);
    atomicAdd(counters.complexity[min(uint(findMSB(total)), uint(DEEP_COMPLEXITY_BINS - 1))], 1u);
}
