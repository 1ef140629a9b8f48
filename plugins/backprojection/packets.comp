#version 460
// The packet pass (Yang, Feng, Guennebaud, Liu 2009 §4.1 and §4.3, Algorithm 1 steps 6
// and 7, Algorithm 2): one invocation per PACKET x PACKET pixels. Each pixel finds its
// own kernel (contour.glsl: step 1, step 5); the pixels whose kernel does not decide
// them (the walkers) share one walk of the packet kernel, the bounding box of theirs:
// each block's samples are read and its contour extracted once, and each walker
// back-projects the edges itself (the integration depends on the receiver). A walker
// takes only the edges of blocks inside its own kernel, so it sums exactly the edges
// of its own walk (where a kernel was cut at the cap, blocks past the cut would add
// others); with TRAVERSAL 0 in the same order, so V is the per-pixel pass's to the bit.
//
// Before walking, §4.3 classifies the packet: non-coherent where eq. 5's probability
// that some sample has the null status exceeds T_d, or where eq. 6's cost model prices
// the packet walk above its pixels' own walks. During the walk a sample that occludes
// some walkers of a block and not others (eq. 3's null status: their contours differ)
// stops it. A non-coherent packet's walkers get V = -1: visibility.comp walks them one
// by one (step 8). So every packet size gives the same V.
//
// The loops over the packet's pixels stay loops, the large ones [[dont_unroll]] (see
// kCellIterations).
#extension GL_EXT_control_flow_attributes : require

#ifndef PACKET
#define PACKET 2
#endif
#define PACKET_PIXELS (PACKET * PACKET)

layout(local_size_x = 8, local_size_y = 8) in;

#include "contour.glsl"

// Per pixel: (V or -1, contour.glsl's class, samples and nodes read, kernel side).
layout(binding = 12, rgba32f) uniform writeonly image2D packetsOut;

// llvmpipe stops an invocation's loops after 65,535 iterations in all, counted per SIMD
// group: a loop iterates as often as its busiest lane. Unrolling the loops over the
// packet's pixels would keep them out of that count but multiplies the shader (a 3 x 3
// packet's took over a minute to compile), so they stay loops and, on such a device
// (pc.loopBudget: backprojection.cpp), the walk charges every iteration any lane might
// run before it runs it: a dual cell kCellIterations whatever its own lane does (its
// four sides, and the loops over the walkers for their masks, their statuses and up to
// two edges), a node 1 + PACKET_PIXELS, a row 1, the setup kSetupIterations per pixel
// (the kernel's three MSSM ranges: mssmRange's rows and fetches) and the classification.
// A packet that would pass the budget stops; its walkers walk alone, each within the
// cap's bound. The small constant loops of contour.glsl and light_area.glsl are
// [[unroll]]ed: they count nothing.
const int kSetupIterations = 24;
const int kCellIterations = 5 + 4 * PACKET_PIXELS;

// The packet's walkers (only their entries with gWalking set mean anything): receiver,
// position, kernel, sum of edges; the light as each sees it (one for all but a point
// light's, whose outline faces each receiver).
ShadowReceiver gReceiver[PACKET_PIXELS];
vec3 gPosition[PACKET_PIXELS];
ivec4 gKernel[PACKET_PIXELS];
float gSum[PACKET_PIXELS];
bool gWalking[PACKET_PIXELS];
#if SHADOW_LIGHT_TYPE == 2
LightPlane gLight[PACKET_PIXELS];
#define WALKER_LIGHT(i) gLight[i]
#else
LightPlane gLight;
#define WALKER_LIGHT(i) gLight
#endif
int gBudget;

// Bit i: walker i's kernel holds cell c.
uint walkersHolding(ivec2 c)
{
    uint mask = 0u;
    for (int i = 0; i < PACKET_PIXELS; ++i) {
        bool holds = all(greaterThanEqual(c, gKernel[i].xy)) && all(lessThanEqual(c, gKernel[i].zw));
        mask |= gWalking[i] && holds ? 1u << i : 0u;
    }
    return mask;
}

// The walkers' reference depths (least, largest) over the samples [a, b] of the face.
vec2 packetReferenceRange(Walk lead, ivec2 a, ivec2 b)
{
    vec2 range = vec2(3.4e38, -3.4e38);
    for (int i = 0; i < PACKET_PIXELS; ++i) {
        lead.r = gReceiver[i];
        vec2 ri = referenceRange(lead, a, b);
        range = gWalking[i] ? vec2(min(range.x, ri.x), max(range.y, ri.y)) : range;
    }
    return range;
}

// One dual cell for the walkers whose kernel holds it (Algorithm 2's loop body). False
// at a null status: a sample that occludes some of them and not others. `reference`:
// the walkers' reference range over the cell's samples where known (the hierarchical
// walk's test of the cell), else the whole line: a sample outside it has one status for
// every walker without comparing it with each.
bool processPacketCell(Walk lead, ivec2 cell, vec2 reference, inout int fetches)
{
    uint holding = walkersHolding(cell);
    if (holding == 0u) return true;
    ivec2 s[4];
    float depth[4];
    bool ignored[4];
    cellSamples(lead, cell, s, depth, ignored);
    fetches += 4;
    bool occ[4], known[4];
    [[unroll]] for (int k = 0; k < 4; ++k) {
        known[k] = depth[k] <= reference.x || depth[k] > reference.y;
        occ[k] = depth[k] > reference.y;
    }
    if (!(known[0] && known[1] && known[2] && known[3])) {
        bool first = true, diverged = false;
        [[dont_unroll]] for (int i = 0; i < PACKET_PIXELS; ++i) {
            if ((holding & (1u << i)) == 0u) continue;
            lead.r = gReceiver[i];
            [[unroll]] for (int k = 0; k < 4; ++k) {
                bool o = known[k] ? occ[k] : occludes(lead, depth[k], sampleUv(lead, s[k]));
                diverged = diverged || (!first && o != occ[k]);
                occ[k] = first ? o : occ[k];
            }
            first = false;
        }
        if (diverged) return false;
    }
    // Each edge extracted once; each walker integrates it.
    [[dont_unroll]] for (int side = 0; side < 4; ++side) {
        vec3 a, b;
        if (!cellEdge(lead, s, depth, occ, side, a, b)) continue;
        [[dont_unroll]] for (int i = 0; i < PACKET_PIXELS; ++i)
            if ((holding & (1u << i)) != 0u) gSum[i] += edgeHidden(WALKER_LIGHT(i), gPosition[i], a, b);
    }
    return true;
}

// Walks the packet kernel k once (Algorithm 2 with TRAVERSAL 0, Algorithm 3 with 1);
// false at a null status or where the loop budget runs out. `lead`: any walker's walk
// (face, origin, range).
bool walkPacket(Walk lead, ivec4 k, inout int fetches, out bool outOfBudget)
{
    outOfBudget = false;
#if TRAVERSAL == 0
    for (int y = k.y; y <= k.w; ++y) {
        for (int x = k.x; x <= k.z; ++x) {
            gBudget -= kCellIterations + (x == k.x ? 1 : 0);
            outOfBudget = gBudget < 0;
            if (outOfBudget) return false;
            if (!processPacketCell(lead, ivec2(x, y), vec2(-3.4e38, 3.4e38), fetches)) return false;
        }
    }
#else
    // A packet kernel may reach past the top level's node (up to twice its side:
    // packetJoins): then the walk starts at the four top-level nodes from its corner.
    ivec2 extent = k.zw - k.xy + 1;
    int top = max(extent.x, extent.y);
    int start = top > 1 ? findMSB(top - 1) + 1 : 0;
    ivec3 stack[3 * MAX_LEVELS + 4];
    int size = 0;
    if (start >= pc.levels) {
        int s = 1 << (pc.levels - 1);
        stack[size++] = ivec3(k.xy + ivec2(s, s), pc.levels - 1);
        stack[size++] = ivec3(k.xy + ivec2(0, s), pc.levels - 1);
        stack[size++] = ivec3(k.xy + ivec2(s, 0), pc.levels - 1);
    }
    stack[size++] = ivec3(k.xy, min(start, pc.levels - 1));
    while (size > 0) {
        ivec3 node = stack[--size];
        gBudget -= 1 + PACKET_PIXELS + (node.z == 0 ? kCellIterations : 0);
        outOfBudget = gBudget < 0;
        if (outOfBudget) return false;
        if (any(greaterThan(node.xy, k.zw))) continue;  // beyond the kernel
        int level = node.z;
        ivec2 last = min(node.xy + (1 << level) - 1, k.zw);
        vec2 depths = mssmNode(0, level, lead.origin + node.xy);
        ++fetches;
        vec2 reference = packetReferenceRange(lead, node.xy, min(last + 1, ivec2(lead.faceTexels - 1)));
        // Fig. 6 cases 4 and 5 for every walker at once.
        if (depths.y <= reference.x || depths.x > reference.y) continue;
        if (level == 0) {
            if (!processPacketCell(lead, node.xy, reference, fetches)) return false;
            continue;
        }
        int h = 1 << (level - 1);
        stack[size++] = ivec3(node.xy + ivec2(h, h), level - 1);
        stack[size++] = ivec3(node.xy + ivec2(0, h), level - 1);
        stack[size++] = ivec3(node.xy + ivec2(h, 0), level - 1);
        stack[size++] = ivec3(node.xy, level - 1);
    }
#endif
    return true;
}

// The cost model's walk of a kernel of side w: every block (flat), or Q_n log(w) w
// nodes (hierarchical, the paper's estimate), plus an edge per block of the side.
float walkCost(float w, float receivers)
{
#if TRAVERSAL == 0
    float nodes = w * w;
#else
    float nodes = log2(max(w, 1.0)) * w;
#endif
    return nodes + (pc.edgeCost + pc.visibilityCost * receivers) * w;
}

// The walkers' references disagree by at most this much at any sample of [a, b]: the
// largest spread over the corners (each reference is the receiver's plane, affine in uv,
// or its own depth past the plane's margin, so the spread, a maximum of differences of
// such, is largest at a corner).
float packetReferenceSpread(ivec2 a, ivec2 b, int faceTexels)
{
    vec4 lo = vec4(3.4e38), hi = vec4(-3.4e38);
    for (int i = 0; i < PACKET_PIXELS; ++i) {
        if (!gWalking[i]) continue;
        [[unroll]] for (int c = 0; c < 4; ++c) {
            vec2 uv = (vec2((c & 1) != 0 ? b.x : a.x, (c & 2) != 0 ? b.y : a.y) + 0.5) / float(faceTexels);
            float ri = shadowReferenceDepth(gReceiver[i], uv);
            lo[c] = min(lo[c], ri);
            hi[c] = max(hi[c], ri);
        }
    }
    vec4 spread = hi - lo;
    return max(max(spread.x, spread.y), max(spread.z, spread.w));
}

// §4.3: the class of a packet with kernel k (walkers only), before its walk.
int packetClass(Walk lead, ivec4 k, int walkers, inout int fetches)
{
    // Eq. 4 and 5: the probability that a sample of the kernel has the null status
    // (falls between the walkers' references at its place), with the kernel's samples
    // spread uniformly over their depth range. The paper's receivers have one depth
    // each, so its band is the packet's depth range; ours have planes, which move the
    // band across the kernel with the receivers' slope, so the band is the walkers'
    // spread at one place (packetReferenceSpread) where it meets the kernel's range.
    vec2 kernelDepths = mssmRange(0, pc.levels, lead.origin + k.xy, lead.origin + k.zw);
    fetches += 4;
    ivec2 far = min(k.zw + 1, ivec2(lead.faceTexels - 1));
    vec2 packetDepths = packetReferenceRange(lead, k.xy, far);
    bool meets = packetDepths.y >= kernelDepths.x && packetDepths.x <= kernelDepths.y;
    float band = packetReferenceSpread(k.xy, far, lead.faceTexels);
    float spread = kernelDepths.y - kernelDepths.x;
    float pNull = !meets ? 0.0 : spread > 0.0 ? min(band / spread, 1.0) : 1.0;
    float side = kernelSide(k);
    // 1 - (1 - P)^(w^2), as exp(w^2 log(1 - P)): the logarithm's argument kept > 0,
    // the exponent <= 0.
    float pDiverge = 1.0 - exp(side * side * log(max(1.0 - pNull, 1e-30)));
    if (pDiverge > pc.divergenceThreshold) return kClassDiverging;
    // Eq. 6.
    float pixelCost = 0.0;
    for (int i = 0; i < PACKET_PIXELS; ++i) pixelCost += gWalking[i] ? walkCost(kernelSide(gKernel[i]), 1.0) : 0.0;
    return walkCost(side, float(walkers)) > pixelCost ? kClassCostly : kClassCoherent;
}

void main()
{
    ivec2 size = imageSize(packetsOut);
    ivec2 base = ivec2(gl_GlobalInvocationID.xy) * PACKET;
    if (any(greaterThanEqual(base, size))) return;

    // The setup, the classification (an MSSM range, three loops over the pixels) and
    // the final loops over the pixels.
    gBudget = pc.loopBudget - PACKET_PIXELS * (kSetupIterations + 6) - kSetupIterations;
    vec4 result[PACKET_PIXELS];
    bool centre[PACKET_PIXELS];
    int walkers = 0;
    Walk lead;  // the first walker's: the packet's face, and the light of all but point lights
    bool oneFace = true, fine = true;  // fine: every walker walks the fine grid (stride 1)
    ivec4 k = ivec4(1 << 30, 1 << 30, -(1 << 30), -(1 << 30));
    [[dont_unroll]] for (int i = 0; i < PACKET_PIXELS; ++i) {
        // A packet past the image's edge repeats its last row or column.
        ivec2 pixel = min(base + ivec2(i % PACKET, i / PACKET), size - 1);
        vec4 position = gbufferPosition(pixel);
        ShadowReceiver r;
        bool inMap = makeShadowReceiver(pixel, position.xyz, 0.0, r);
        LightPlane light = lightPlaneFor(position.xyz);
        bool hasSize = light.area > 0.0 && shadowMapData.faces[r.face].texel.x > 0.0;
        bool soften = inMap && position.w != 0.0 && hasSize;
        // Without geometry, outside the map or without a light size: visibility.comp.
        vec4 res = vec4(-1.0, float(soften ? kClassPerPixel : kClassNone), 0.0, 0.0);
        Walk w = startWalk(r, position.xyz, light);
        ivec4 kernel = ivec4(0);
        bool walking = false, hidden = false;
        if (soften) {
            float v = receiverKernel(w, kernel);
            walking = v < 0.0;
            if (walking) hidden = centreOccluded(w);
            res = vec4(v, float(kClassDecided), float(w.fetches), kernelSide(kernel));
            if (walking) {
                oneFace = oneFace && (walkers == 0 || r.face == lead.r.face);
                fine = fine && w.stride == 1;
                if (walkers == 0) lead = w;
                k = ivec4(min(k.xy, kernel.xy), max(k.zw, kernel.zw));
                ++walkers;
            }
        }
        result[i] = res;
        centre[i] = hidden;
        gReceiver[i] = r;
        gPosition[i] = position.xyz;
        gKernel[i] = kernel;
        gSum[i] = 0.0;
        gWalking[i] = walking;
#if SHADOW_LIGHT_TYPE == 2
        gLight[i] = light;
#endif
    }

    if (walkers > 0) {
#if SHADOW_LIGHT_TYPE != 2
        gLight = lead.light;
#endif
        // A packet walks as one within a face and where its kernel is at most twice the
        // MSSM's top node (walkPacket starts from four of them); a lone walker's packet
        // walk is its own walk.
        bool joins = oneFace && fine && kernelSide(k) <= float(2 << (pc.levels - 1));
        int walkFetches = 0;
        bool classify = pc.classify != 0 && walkers > 1;
        int kind = !joins ? kClassPerPixel : classify ? packetClass(lead, k, walkers, walkFetches) : kClassCoherent;
        bool outOfBudget = false;
        if (kind == kClassCoherent && !walkPacket(lead, k, walkFetches, outOfBudget))
            kind = outOfBudget ? kClassPerPixel : kClassNullStatus;
        bool joined = kind == kClassCoherent;
        // The debug image: each walker's own reads and its share of the packet's.
        float share = float(walkFetches) / float(walkers);
        [[dont_unroll]] for (int i = 0; i < PACKET_PIXELS; ++i) {
            if (!gWalking[i]) continue;
            Walk w = lead;
            w.r = gReceiver[i];
            w.p = gPosition[i];
            w.light = WALKER_LIGHT(i);
            w.sum = gSum[i];
            float v = joined ? contourVisibility(w, centre[i]) : -1.0;
            result[i] = vec4(v, float(kind), result[i].z + (joined ? share : 0.0), result[i].w);
        }
    }

    for (int i = 0; i < PACKET_PIXELS; ++i) {
        ivec2 pixel = base + ivec2(i % PACKET, i / PACKET);
        if (all(lessThan(pixel, size))) imageStore(packetsOut, pixel, result[i]);
    }
}
