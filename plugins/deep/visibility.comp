#version 460
// The deep shadow map lookup (§1.3.4, deferred: once per G-buffer pixel): the receiver is
// projected into the light's atlas (common/shadow_receiver.glsl) and
// the transmittance at its depth read from its texel's sorted list; V is that, filtered.
//
// Defines (deep.cpp visibilityDefines):
//   PCF_KERNEL   1, 3, 5, 7: taps per side of a box of texels centred on the receiver's
//                (percentage-closer filtering of the transmittance, §1.3.5)
//   LOOKUP       0 linked: the lower-left tap searches its list from the head, every other
//                tap starts at the node its neighbour's links point to (up the first
//                column, then along each row) and walks prev or next from there;
//                1 brute force: every tap searches its own list from its head
//   RECEIVER_BIAS 0: the stored depths carry the bias (bias_mode slope); 1: the receiver
//                moves along its normal (bias_mode normal_offset)
//   FILTER       0 DSM: a node darkens a receiver behind it fully;
//                1 EDSM: the node nearest in front of the receiver darkens it by the
//                exponential shadow test 1 - e^{-c (t_r - t_n)} (t: linear depth along the
//                face, c: esmExponent), the rest fully;
//                2 first fragment: each tap compares with its list's first node only, a
//                binary shadow map made from the lists (Table 1.1's "SM": the cost of
//                building the structure without the cost of walking it)
#define GBUFFER_BINDING 4  // gDepth, gNormal, GBufferCamera: plugin::bindGBuffer
#include "common/gbuffer.glsl"
#include "common/visibility.glsl"

#ifndef PCF_KERNEL
#define PCF_KERNEL 1
#endif
#ifndef LOOKUP
#define LOOKUP 0
#endif
#ifndef FILTER
#define FILTER 0
#endif
#define FILTER_DSM 0
#define FILTER_EDSM 1
#define FILTER_FIRST_FRAGMENT 2
#define LOOKUP_LINKED 0
#define LOOKUP_BRUTE_FORCE 1

layout(local_size_x = 64, local_size_y = 1) in;

layout(binding = 1, r32ui) uniform readonly uimage2D heads;
layout(binding = 2, VISIBILITY_FORMAT) uniform writeonly image2D visibilityOut;

#ifndef RECEIVER_BIAS
#define RECEIVER_BIAS 1
#endif
#define SHADOW_MAP_BINDING 3
#define SHADOW_RECEIVER_BIAS RECEIVER_BIAS
#include "common/shadow_receiver.glsl"

#define DEEP_NODES_BINDING 7
#include "deep_lists.glsl"

layout(push_constant) uniform Push {
    float normalOffsetTexels;
    float esmExponent;  // FILTER 1
} pc;

// The transmittance a tap reads where the receiver's search ended at `node`.
float tapTransmittance(uint node, float receiverLinear, vec4 range)
{
#if FILTER == FILTER_EDSM
    if (node == kDeepNone) return 1.0;
    float before = deepTransmittance(nodes[node].prev);
    float gap = max(receiverLinear - shadowLinearDepthInRange(range, nodes[node].depth), 0.0);
    float occlusion = 1.0 - exp(-min(pc.esmExponent * gap, 80.0));
    return mix(before, nodes[node].transmittance, occlusion);
#else
    return deepTransmittance(node);
#endif
}

// The atlas texel of the tap `offset` texels from the receiver, inside its face.
ivec2 tapTexel(ShadowReceiver r, ivec2 offset)
{
    vec2 uv = shadowTapUv(r, vec2(offset));
    ivec2 cell = ivec2(int(r.face % 3u), int(r.face / 3u)) * int(shadowFaceTexels());
    return cell + ivec2(floor(uv * shadowFaceTexels()));
}

float filteredTransmittance(ShadowReceiver r)
{
    const int h = (PCF_KERNEL - 1) / 2;
    vec4 range = shadowMapData.faces[r.face].depthRange;
    float receiverLinear = shadowLinearDepthInRange(range, r.depth);
    float sum = 0.0;
#if FILTER == FILTER_FIRST_FRAGMENT
    for (int y = -h; y <= h; ++y)
        for (int x = -h; x <= h; ++x) {
            uint head = imageLoad(heads, tapTexel(r, ivec2(x, y))).r;
            sum += head != kDeepNone && nodes[head].depth > r.depth ? 0.0 : 1.0;
        }
#elif LOOKUP == LOOKUP_BRUTE_FORCE
    for (int y = -h; y <= h; ++y)
        for (int x = -h; x <= h; ++x) {
            ivec2 t = tapTexel(r, ivec2(x, y));
            uint node = deepSeek(imageLoad(heads, t).r, kDeepNone, r.depth);
            sum += tapTransmittance(node, receiverLinear, range);
        }
#else
    // Fig. 1.5: from the lower-left tap up the first column by `upper`, then along each
    // row by `right`. A tap clamped onto its neighbour's texel (at a face's edge) starts
    // at its neighbour's node; one whose neighbour found no node nearer than the
    // receiver starts at its own head.
    ivec2 columnTexel = tapTexel(r, ivec2(-h, -h));
    uint columnNode = deepSeek(imageLoad(heads, columnTexel).r, kDeepNone, r.depth);
    for (int y = -h; y <= h; ++y) {
        if (y > -h) {
            ivec2 t = tapTexel(r, ivec2(-h, y));
            uint guess = t == columnTexel ? columnNode : (columnNode == kDeepNone ? kDeepNone : nodes[columnNode].upper);
            columnNode = deepSeek(imageLoad(heads, t).r, guess, r.depth);
            columnTexel = t;
        }
        sum += tapTransmittance(columnNode, receiverLinear, range);
        ivec2 rowTexel = columnTexel;
        uint rowNode = columnNode;
        for (int x = -h + 1; x <= h; ++x) {
            ivec2 t = tapTexel(r, ivec2(x, y));
            uint guess = t == rowTexel ? rowNode : (rowNode == kDeepNone ? kDeepNone : nodes[rowNode].right);
            rowNode = deepSeek(imageLoad(heads, t).r, guess, r.depth);
            rowTexel = t;
            sum += tapTransmittance(rowNode, receiverLinear, range);
        }
    }
#endif
    return sum / float(PCF_KERNEL * PCF_KERNEL);
}

void main()
{
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(visibilityOut);
    if (any(greaterThanEqual(pixel, size))) return;

    vec4 position = gbufferPosition(pixel);
    ShadowReceiver r;
    bool inMap = position.w != 0.0 && makeShadowReceiver(pixel, position.xyz, pc.normalOffsetTexels, r);
    float transmittance = inMap ? filteredTransmittance(r) : 1.0;
    float v = shadowVisibilityAboveHorizon(transmittance, position.xyz, gbufferNormal(pixel));
    v = position.w != 0.0 ? v : VISIBILITY_NO_GEOMETRY;
    imageStore(visibilityOut, pixel, vec4(sanitizeVisibility(v)));
}
