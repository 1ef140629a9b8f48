// The deep shadow map's structure (Fürst, Mattausch, Scherzer, "Real-Time Deep Shadow
// Maps", §1.3.1, Listing 1.1): per texel of the light's atlas a linked list of every
// caster fragment, its head in the `heads` image (kDeepNone: empty), its nodes in one
// pool. After the sort pass (sort.comp) a list runs from the light outwards, each node
// holding the transmittance behind it (eq. 1.1), with `prev` links; the links pass
// (links.comp) adds the depth-nearest node of the right and upper neighbours' lists.
//
// Depths are the map's: reversed-Z NDC (common/shadow_map.glsl), so nearer to the light
// is larger. The including shader defines DEEP_NODES_BINDING (and DEEP_NODES_WRITE when
// it writes nodes) before including this file.
#ifndef PENUMBRA_DEEP_LISTS_GLSL
#define PENUMBRA_DEEP_LISTS_GLSL

#ifndef DEEP_NODES_BINDING
#error deep_lists.glsl: define DEEP_NODES_BINDING first
#endif

const uint kDeepNone = 0xFFFFFFFFu;

// Listing 1.1, 24 bytes (std430; deep.cpp kNodeBytes).
struct DeepNode {
    float depth;  // reversed-Z NDC depth of the fragment
    // The fragment's alpha as the fragment pass stores it; after the sort pass the
    // transmittance behind it: the product of (1 - alpha) over it and every nearer node.
    float transmittance;
    uint next;   // farther from the light
    uint prev;   // nearer (sort pass)
    uint right;  // depth-nearest node of the list at texel + (1, 0) (links pass)
    uint upper;  // and at texel + (0, 1)
};

#ifdef DEEP_NODES_WRITE
layout(std430, binding = DEEP_NODES_BINDING) buffer DeepNodes { DeepNode nodes[]; };
#else
layout(std430, binding = DEEP_NODES_BINDING) readonly buffer DeepNodes { DeepNode nodes[]; };
#endif

// The longest list the sort pass keeps (deep.cpp kSortCapacity): it sorts a list in a
// local array (§1.3.2), keeping the kDeepSortCapacity nodes nearest to the light.
#ifndef DEEP_SORT_CAPACITY
#define DEEP_SORT_CAPACITY 256
#endif

// Where a receiver at depth `ref` sits in a sorted list: its last node nearer to the
// light than `ref` (reversed-Z: depth > ref), whose transmittance is the light that
// reaches the receiver; kDeepNone when no node is nearer (all the light). The walk
// starts at `guess` (a node of this list: a neighbour's link, §1.3.5) and moves along
// next or prev; kDeepNone starts at `head`. Bounded by the longest list the sort keeps.
uint deepSeek(uint head, uint guess, float ref)
{
    uint n = guess == kDeepNone ? head : guess;
    if (n == kDeepNone) return kDeepNone;
    if (nodes[n].depth > ref) {
        for (int i = 0; i < DEEP_SORT_CAPACITY; ++i) {
            uint next = nodes[n].next;
            if (next == kDeepNone || !(nodes[next].depth > ref)) break;
            n = next;
        }
        return n;
    }
    for (int i = 0; i < DEEP_SORT_CAPACITY; ++i) {
        n = nodes[n].prev;
        if (n == kDeepNone || nodes[n].depth > ref) break;
    }
    return n;
}

float deepTransmittance(uint node)
{
    return node == kDeepNone ? 1.0 : nodes[node].transmittance;
}

#endif
