// One receiver's contour, shared by the per-pixel pass (visibility.comp) and the packet
// pass (packets.comp): the light as the receiver sees it, its kernel in the shadow map
// (step 1 and step 5 of visibility.comp's outline), the marching squares on the dual grid
// and the back-projection of each edge (steps 2 and 3), and V from the edges' sum.
// The including shader defines TRAVERSAL (0 flat, 1 hierarchical), LAYERS (1, or 2 for a
// depth-peeled second layer: backprojectionVisibility) and its outputs.
#ifndef PENUMBRA_BACKPROJECTION_CONTOUR_GLSL
#define PENUMBRA_BACKPROJECTION_CONTOUR_GLSL
// llvmpipe stops an invocation's loops after 65,535 iterations in all (every loop's
// iterations count: backprojection.cpp kCpuMaxKernel), so the small loops with a
// constant trip count are [[unroll]]ed; only the kernel walk and processCell's sides
// iterate.
#extension GL_EXT_control_flow_attributes : require
#define GBUFFER_BINDING 6  // gDepth, gNormal, GBufferCamera: plugin::bindGBuffer
#include "common/gbuffer.glsl"
#include "common/visibility.glsl"

#ifndef TRAVERSAL
#define TRAVERSAL 1
#endif
#ifndef LAYERS
#define LAYERS 1
#endif
// The levels the plugin builds at most (backprojection.cpp kMaxLevels): the stack holds
// three siblings per level and the node being visited.
#define MAX_LEVELS 14

layout(binding = 1) uniform sampler2DShadow shadowCompare;
layout(binding = 5) uniform sampler2D shadowDepth;  // the same map, raw depths
#if LAYERS > 1
// The second depth layer (render::ShadowMap::addPeeledDepthPass): per texel the nearest
// surface behind the first layer's, raw depths; its MSSM lies right of the first's in
// mssmImage (mssm.glsl).
layout(binding = 15) uniform sampler2D peeledDepth;
#endif

#define SHADOW_MAP_BINDING 3
#define SHADOW_RECEIVER_BIAS 2
#include "common/shadow_receiver.glsl"

#define MSSM_BINDING 4
#define MSSM_QUALIFIER readonly
#include "mssm.glsl"
#include "light_area.glsl"
#if LAYERS > 1
#include "light_samples.glsl"
#endif

// How a pixel's V was found (the `coherence` debug image; packets.comp, Yang et al. 2009
// §4.1 and §4.3): no geometry or outside the map (or no light size: the hard compare),
// decided by its own kernel (step 5), in a coherent packet's one walk, or by its own walk
// after its packet was found non-coherent by eq. 5 (the contours likely diverge), by
// eq. 6 (the packet walk costs more than its pixels'), or by a null status (eq. 3) met
// during the packet walk, or because it walks alone (packets of 1 x 1, a packet across
// two cube faces, a packet kernel past the cap).
const int kClassNone = 0;
const int kClassDecided = 1;
const int kClassCoherent = 2;
const int kClassDiverging = 3;
const int kClassCostly = 4;
const int kClassNullStatus = 5;
const int kClassPerPixel = 6;

// A face's texels back to the world: the point of face uv `uv` at distance `dist` along
// the face's axis is base0 + u baseU + v baseV + dist (dir0 + u dirU + v dirV)
// (perspective: base is the light's centre; orthographic: dir is the axis). Set up in
// double precision from the face's view-projection (backprojection.cpp).
struct FaceFrame {
    vec4 base0, baseU, baseV, dir0, dirU, dirV;
};

layout(std430, binding = 9) readonly buffer BackprojectionLight {
    vec4 centre;     // xyz: the light's centre (lights at a position)
    vec4 normal;     // xyz: unit normal of the light's plane, towards the scene; directional: unit towards the light
    vec4 tangent;    // xyz: the plane's first axis (rect: its width axis)
    vec4 bitangent;  // xyz: normal x tangent
    // x, y: half width and half height of a rectangle; x: radius of a disk (directional:
    // tan of the angular radius, on the plane one unit towards the light); z: 1 for a
    // disk; w: a point light's sphere radius (the disk is then the sphere's outline as
    // the receiver sees it, on the plane through its centre facing the receiver).
    vec4 extent;
    FaceFrame faces[6];
} bp;

layout(push_constant) uniform Push {
    int levels;      // of the MSSM: 2^(levels - 1) >= maxKernel
    int maxKernel;   // the kernel cap: cells per side
    float edgeCost;        // packets.comp: Q_e of eq. 6 (Q_n = 1)
    float visibilityCost;  // packets.comp: Q_v of eq. 6
    float divergenceThreshold;  // packets.comp: T_d of eq. 5
    int loopBudget;             // packets.comp: loop iterations a packet's walk may run
    int classify;               // packets.comp: 1 eq. 5 and 6 decide, 0 every packet walks as one
} pc;


struct LightPlane {
    vec3 centre, normal, t1, t2;
    vec2 halfSize;  // rectangle: half sizes; disk: (radius, radius)
    bool disk;
    float area;
};

LightPlane lightPlaneFor(vec3 p)
{
    LightPlane l;
    l.centre = bp.centre.xyz;
    l.normal = bp.normal.xyz;
    l.t1 = bp.tangent.xyz;
    l.t2 = bp.bitangent.xyz;
    vec4 extent = bp.extent;
    l.disk = extent.z != 0.0;
    l.halfSize = l.disk ? extent.xx : extent.xy;
#if SHADOW_LIGHT_TYPE == 2
    // A sphere of radius R at distance d: its outline is the circle where the cone of
    // half-angle asin(R / d) from p meets the plane through the centre facing p, radius
    // R d / sqrt(d^2 - R^2). Inside the sphere: radius 0, so the hard compare.
    vec3 d = p - l.centre;
    float dist = length(d);
    float radius = extent.w;
    l.normal = dist > 0.0 ? d / dist : vec3(0.0, 1.0, 0.0);
    l.t1 = normalize(cross(l.normal, abs(l.normal.y) < 0.9 ? vec3(0.0, 1.0, 0.0) : vec3(1.0, 0.0, 0.0)));
    l.t2 = cross(l.normal, l.t1);
    float outline = dist > radius ? radius * dist / sqrt(dist * dist - radius * radius) : 0.0;
    l.halfSize = vec2(outline);
#endif
    l.area = l.disk ? 3.14159265358979 * l.halfSize.x * l.halfSize.x : 4.0 * l.halfSize.x * l.halfSize.y;
    return l;
}

// A point far outside the light in the direction q of the plane (for a contour point
// whose ray from the receiver never meets the light's plane).
vec2 farOutside(vec2 q, LightPlane l)
{
    float len = length(q);
    float far = 1e4 * max(max(l.halfSize.x, l.halfSize.y), 1e-30);
    return len > 0.0 ? q * (far / len) : vec2(far, 0.0);
}

// The light-plane coordinates of the ray from the receiver p through the contour point e.
vec2 backproject(LightPlane l, vec3 p, vec3 e)
{
    vec3 d = e - p;
    vec2 across = vec2(dot(d, l.t1), dot(d, l.t2));
#if SHADOW_LIGHT_TYPE == 0
    // Directional: the plane one unit towards the light (gnomonic projection of the
    // directions; the sun's disk of angular radius rho is a disk of radius tan(rho)).
    float along = dot(d, l.normal);
    return along > 0.0 ? across / along : farOutside(across, l);
#else
    float towards = dot(d, l.normal);        // < 0: towards the light's side
    float gap = dot(l.centre - p, l.normal);  // < 0: p is on the lit side of the plane
    vec3 x = p + d * (gap / (towards < 0.0 ? towards : -1.0)) - l.centre;
    return towards < 0.0 && gap < 0.0 ? vec2(dot(x, l.t1), dot(x, l.t2)) : farOutside(across, l);
#endif
}

vec3 unprojectFace(uint face, vec2 uv, float ndc, vec4 range)
{
    FaceFrame f = bp.faces[face];
    float dist = shadowDistanceInRange(range, ndc);
    return f.base0.xyz + uv.x * f.baseU.xyz + uv.y * f.baseV.xyz +
           dist * (f.dir0.xyz + uv.x * f.dirU.xyz + uv.y * f.dirV.xyz);
}

// Distance along the face's axis (linear in x: clip w, or the orthographic depth).
float axisDistance(uint face, vec3 x, vec4 range)
{
    vec4 clip = shadowMapData.faces[face].viewProj * vec4(x, 1.0);
#if SHADOW_LIGHT_TYPE == 0
    return mix(range.y, range.x, clip.z);
#else
    return clip.w;
#endif
}

// Everything one receiver needs while it walks its kernel.
struct Walk {
    ShadowReceiver r;
    vec3 p;
    LightPlane light;
    vec4 range;      // the face's depthRange
    ivec2 origin;    // the face's first texel in the atlas
    int faceTexels;
    int layer;       // the depth layer it walks: 0, or 1 (peeledDepth)
    // The samples' spacing in texels (a power of two): 1, or coarser where the kernel is
    // wider than the cap (receiverKernel), so that the walk's cells stay within it.
    int stride;
    int mssmBase;    // the layer's first array layer in mssmImage (mssm.glsl)
    float sum;       // of the edges' signed hidden areas (light_area.glsl)
    int fetches;     // depth-map and MSSM reads (the debug image)
#if LAYERS > 1
    LightSamples hidden;  // the light samples the layer's contour hides (light_samples.glsl)
#endif
};

float sampleDepth(inout Walk w, ivec2 s)
{
#if LAYERS > 1
    if (w.layer != 0) return texelFetch(peeledDepth, w.origin + s, 0).r;
#endif
    return texelFetch(shadowDepth, w.origin + s, 0).r;
}

vec2 sampleUv(Walk w, ivec2 s)
{
    return (vec2(s) + 0.5) / float(w.faceTexels);
}

// An occluder: nearer the light than the receiver's plane at the sample (the exact
// negation of the compare sampler's "lit").
bool occludes(Walk w, float depth, vec2 uv)
{
    return depth > shadowReferenceDepth(w.r, uv);
}

// The reference depths (least, largest) over the samples [a, b] of the face: the
// receiver's plane is linear, and the margin's max() keeps the order.
vec2 referenceRange(Walk w, ivec2 a, ivec2 b)
{
    vec2 ua = sampleUv(w, a), ub = sampleUv(w, b);
    float r00 = shadowReferenceDepth(w.r, ua), r11 = shadowReferenceDepth(w.r, ub);
    float r10 = shadowReferenceDepth(w.r, vec2(ub.x, ua.y)), r01 = shadowReferenceDepth(w.r, vec2(ua.x, ub.y));
    return vec2(min(min(r00, r11), min(r10, r01)), max(max(r00, r11), max(r10, r01)));
}

// The 2 x 2 samples of dual cell `cell` in counter-clockwise order (00, 10, 11, 01),
// clamped into the face. At a stride s > 1 the cell is one of the coarse grid's: its
// samples are the texels s apart at s cell and s (cell + 1), a map of 1/s the resolution.
void cellSamples(inout Walk w, ivec2 cell, out ivec2 s[4], out float depth[4], out bool occ[4])
{
    ivec2 a = min(cell * w.stride, ivec2(w.faceTexels - 1));
    ivec2 b = min(cell * w.stride + w.stride, ivec2(w.faceTexels - 1));
    s = ivec2[4](a, ivec2(b.x, a.y), b, ivec2(a.x, b.y));
    [[unroll]] for (int k = 0; k < 4; ++k) {
        depth[k] = sampleDepth(w, s[k]);
        occ[k] = occludes(w, depth[k], sampleUv(w, s[k]));
    }
    w.fetches += 4;
}

// Marching squares: the side after `side` (counter-clockwise) where the boundary that
// leaves the occluders through `side` enters them again (occ[side] is true, so within
// two more sides). Written without a loop: every loop iteration counts against
// llvmpipe's limit (backprojection.cpp kCpuMaxKernel).
int contourExitSide(bool occ[4], int side)
{
    if (occ[(side + 2) % 4]) return side + 1;
    return occ[(side + 3) % 4] ? side + 2 : side + 3;
}

// Where the contour crosses the side from the occluding sample `o` to the free sample
// `f` (texels of one row or column, at most a stride apart): their midpoint on the fine
// grid (stride 1: o and f are neighbours), else the fine transition found by halving the
// side (the first found, where thin occluders cross it several times), so that a coarse
// walk's edges lie where the map's own samples put them, not up to half a stride off.
// `occDepth`: the occluding sample's depth at the transition. Written out, not as a
// loop: every loop iteration counts against llvmpipe's limit (backprojection.cpp
// kCpuMaxKernel), and a halving per end of every edge would pass it.
void halveSide(inout Walk w, inout ivec2 o, inout ivec2 f, inout float occDepth)
{
    ivec2 gap = abs(f - o);
    if (max(gap.x, gap.y) <= 1) return;
    ivec2 mid = (o + f) / 2;
    float d = sampleDepth(w, mid);
    ++w.fetches;
    bool hides = occludes(w, d, sampleUv(w, mid));
    o = hides ? mid : o;
    f = hides ? f : mid;
    occDepth = hides ? d : occDepth;
}

// The most halvings of a coarse cell's side (strides up to 2^kMaxRefinements: a kernel
// of 128 caps, more than a face).
const int kMaxRefinements = 7;

vec2 sideCrossing(inout Walk w, ivec2 o, ivec2 f, inout float occDepth)
{
    halveSide(w, o, f, occDepth);
    halveSide(w, o, f, occDepth);
    halveSide(w, o, f, occDepth);
    halveSide(w, o, f, occDepth);
    halveSide(w, o, f, occDepth);
    halveSide(w, o, f, occDepth);
    halveSide(w, o, f, occDepth);
    return 0.5 * (sampleUv(w, o) + sampleUv(w, f));
}

// The map positions (uv) of the edge that leaves the occluders through `side`, and the
// depths its ends take; false when no edge leaves through it.
bool edgeUv(inout Walk w, ivec2 s[4], float depth[4], bool occ[4], int side, out vec2 ua, out vec2 ub, out float da,
            out float db)
{
    ua = vec2(0.0);
    ub = vec2(0.0);
    da = 0.0;
    db = 0.0;
    if (!occ[side] || occ[(side + 1) % 4]) return false;
    int next = contourExitSide(occ, side);
    int a0 = side, a1 = (side + 1) % 4, b0 = next % 4, b1 = (next + 1) % 4;
    da = depth[a0];
    db = depth[b1];
    ua = sideCrossing(w, s[a0], s[a1], da);
    ub = sideCrossing(w, s[b1], s[b0], db);
    return true;
}

// Marching squares on one dual cell (samples s, depths, statuses occ in counter-clockwise
// order): each edge runs from the crossing (sideCrossing) of a side where the boundary
// leaves the occluders (counter-clockwise) to the next side where it enters them, with
// the occluders on its left; a saddle keeps its two occluders joined (the free corners are
// cut off), as centreOccluded() does. An endpoint takes the depth of its side's
// occluding sample. True when an edge leaves through `side`: its world endpoints a, b.
bool cellEdge(inout Walk w, ivec2 s[4], float depth[4], bool occ[4], int side, out vec3 a, out vec3 b)
{
    vec2 ua, ub;
    float da, db;
    bool edge = edgeUv(w, s, depth, occ, side, ua, ub, da, db);
    a = edge ? unprojectFace(w.r.face, ua, da, w.range) : vec3(0.0);
    b = edge ? unprojectFace(w.r.face, ub, db, w.range) : vec3(0.0);
    return edge;
}

// The hidden area of edge a -> b as the receiver at p sees it: back-projected onto the
// light and integrated (light_area.glsl).
float edgeHidden(LightPlane l, vec3 p, vec3 a, vec3 b)
{
    return edgeBeyond(backproject(l, p, a), backproject(l, p, b), l.halfSize, l.disk);
}

// One dual cell of the receiver's walk: its edges, back-projected and added. The loop
// over the sides is not unrolled: four copies of its body ran the per-pixel pass 1.15
// times as long on llvmpipe (306 against 266 ms, config/default.json's spot at
// 480 x 270, alternated runs); its 4 iterations a cell count against the loop limit
// (backprojection.cpp kCpuMaxKernel).
void processCell(inout Walk w, ivec2 cell)
{
    ivec2 s[4];
    float depth[4];
    bool occ[4];
    cellSamples(w, cell, s, depth, occ);
    [[dont_unroll]] for (int side = 0; side < 4; ++side) {
        vec3 a, b;
        if (!cellEdge(w, s, depth, occ, side, a, b)) continue;
        vec2 la = backproject(w.light, w.p, a), lb = backproject(w.light, w.p, b);
        w.sum += edgeBeyond(la, lb, w.light.halfSize, w.light.disk);
#if LAYERS > 1
        lightSamplesFlipBeyond(w.hidden, la, lb, w.light.halfSize);
#endif
    }
}

// Is the light's centre hidden: the receiver's own point in the map inside the contour
// (the hard shadow, with the contour's geometry rather than the nearest sample's).
bool centreOccluded(inout Walk w)
{
    vec2 t = (w.r.uv * float(w.faceTexels) - 0.5) / float(w.stride);
    ivec2 cell = clamp(ivec2(floor(t)), ivec2(0), ivec2((w.faceTexels - 1) / w.stride));
    vec2 f = clamp(t - vec2(cell), 0.0, 1.0);
    ivec2 s[4];
    float depth[4];
    bool occ[4];
    cellSamples(w, cell, s, depth, occ);
    if (w.stride > 1) {
        // On the coarse grid the edges' ends are refined (sideCrossing): the receiver is
        // hidden where it lies on the occluders' side of every edge in its cell (the side
        // of the edge's occluding corner), or, with none, where the corners occlude.
        bool inside = occ[0];
        bool any = false;
        vec2 uv = w.r.uv;
        [[unroll]] for (int side = 0; side < 4; ++side) {
            vec2 ua, ub;
            float da, db;
            if (!edgeUv(w, s, depth, occ, side, ua, ub, da, db)) continue;
            vec2 e = ub - ua, toCorner = sampleUv(w, s[side]) - ua, toPoint = uv - ua;
            bool same = (e.x * toCorner.y - e.y * toCorner.x) * (e.x * toPoint.y - e.y * toPoint.x) >= 0.0;
            inside = any ? inside && same : same;
            any = true;
        }
        return inside;
    }
    // The quadrant's corner k and its neighbours; corner k sits at (kx, ky).
    bool right = f.x >= 0.5, up = f.y >= 0.5;
    int k = up ? (right ? 2 : 3) : (right ? 1 : 0);
    vec2 corner = vec2(right ? 1.0 : 0.0, up ? 1.0 : 0.0);
    bool beyondDiagonal = abs(f.x - corner.x) + abs(f.y - corner.y) >= 0.5;
    bool a = occ[(k + 3) % 4], b = occ[(k + 1) % 4], o = occ[(k + 2) % 4];
    return occ[k] ? (a || b || o || !beyondDiagonal) : (a && b && beyondDiagonal);
}

// The kernel (cells, inclusive, clamped into the face and to the cap) for occluders at
// distance z along the face's axis or farther: the bounding box of the receiver's own
// map position and of the light's corners as seen from the receiver at that depth
// (a disk's bounding square). A corner the projection cannot place (behind the light)
// makes it the cap.
ivec4 kernelAt(inout Walk w, float z, float wp, ivec2 centreCell, int cap)
{
    vec2 lo = w.r.uv, hi = w.r.uv;
    bool bounded = true;
    [[unroll]] for (int k = 0; k < 4; ++k) {
        vec2 o = vec2((k & 1) != 0 ? 1.0 : -1.0, (k & 2) != 0 ? 1.0 : -1.0) * w.light.halfSize;
#if SHADOW_LIGHT_TYPE == 0
        vec3 x = w.p + max(wp - z, 0.0) * (w.light.normal + o.x * w.light.t1 + o.y * w.light.t2);
#else
        vec3 l = w.light.centre + o.x * w.light.t1 + o.y * w.light.t2;
        float wl = axisDistance(w.r.face, l, w.range);
        float t = wp - wl > 0.0 ? clamp((wp - z) / (wp - wl), 0.0, 1.0) : 1.0;
        vec3 x = w.p + t * (l - w.p);
#endif
        vec3 uvDepth;
        float clipW;
        bounded = bounded && shadowProject(w.r.face, x, uvDepth, clipW);
        lo = min(lo, uvDepth.xy);
        hi = max(hi, uvDepth.xy);
    }
    float n = float(w.faceTexels);
    // Clamped before the conversion to int (no overflow, no NaN: constant first).
    vec2 loT = clamp(lo * n - 0.5, -2.0, n + 1.0), hiT = clamp(hi * n - 0.5, -2.0, n + 1.0);
    ivec2 a = ivec2(floor(loT)) - 1, b = ivec2(floor(hiT)) + 1;
    int below = cap / 2, above = cap - 1 - cap / 2;
    a = bounded ? max(a, centreCell - below) : centreCell - below;
    b = bounded ? min(b, centreCell + above) : centreCell + above;
    return ivec4(clamp(a, ivec2(0), ivec2(w.faceTexels - 1)), clamp(b, ivec2(0), ivec2(w.faceTexels - 1)));
}

vec2 kernelRange(inout Walk w, ivec4 k)
{
    w.fetches += 4;
    return mssmRange(w.mssmBase, pc.levels, w.origin + k.xy, w.origin + k.zw);
}

// Walks kernel k (fine cells, inclusive) on the grid of the walk's stride: its cells are
// the coarse cells that hold k's. Every receiver runs the same loops, whatever its stride
// (llvmpipe counts a loop's iterations per SIMD group: two loops, one per stride, would
// add up).
void walkKernel(inout Walk w, ivec4 k, int levels)
{
    int stride = w.stride;
    ivec4 c = k / stride;  // the coarse cells
#if TRAVERSAL == 0
    for (int y = c.y; y <= c.w; ++y)
        for (int x = c.x; x <= c.z; ++x) processCell(w, ivec2(x, y));
#else
    // The MSSM's nodes of level log2(stride), anchored at multiples of the stride, cover
    // a coarse cell's samples and the fine ones between them (its sides' halvings): they
    // are the walk's leaves, and their ranges prune as the fine walk's do. A kernel wider
    // than the top level's nodes starts from several of them.
    int leaf = findMSB(stride);
    ivec2 first = c.xy * stride, lastAnchor = c.zw * stride;
    ivec2 end = min(lastAnchor + stride - 1, ivec2(w.faceTexels - 1));  // the fine cells' end
    ivec2 extent = lastAnchor + stride - first;
    int top = max(extent.x, extent.y);
    int start = clamp(top > 1 ? findMSB(top - 1) + 1 : 0, leaf, levels - 1);  // 2^start >= the side, at most the top
    ivec2 roots = (extent + (1 << start) - 1) >> start;
    ivec3 stack[3 * MAX_LEVELS + 1];
    for (int root = 0; root < roots.x * roots.y; ++root) {
        int size = 0;
        stack[size++] = ivec3(first + ivec2(root % roots.x, root / roots.x) * (1 << start), start);
        while (size > 0) {
            ivec3 node = stack[--size];
            if (any(greaterThan(node.xy, lastAnchor))) continue;  // beyond the kernel
            int level = node.z;
            ivec2 last = min(node.xy + (1 << level) - 1, end);
            vec2 depths = mssmNode(w.mssmBase, level, w.origin + node.xy);
            ++w.fetches;
            vec2 reference = referenceRange(w, node.xy, min(last + 1, ivec2(w.faceTexels - 1)));
            // Fig. 6 cases 4 and 5: every sample behind the receiver, or every one in front.
            if (depths.y <= reference.x || depths.x > reference.y) continue;
            if (level == leaf) {
                processCell(w, node.xy / stride);
                continue;
            }
            int h = 1 << (level - 1);
            stack[size++] = ivec3(node.xy + ivec2(h, h), level - 1);
            stack[size++] = ivec3(node.xy + ivec2(0, h), level - 1);
            stack[size++] = ivec3(node.xy + ivec2(h, 0), level - 1);
            stack[size++] = ivec3(node.xy, level - 1);
        }
    }
#endif
}

// The refinements of the kernel after the first (SS07's iteration: each finds the
// nearest occluder in the last kernel, which can only shrink it).
const int kKernelRefinements = 2;

// A receiver's walk, before its kernel: `light` is lightPlaneFor(p).
Walk startWalk(ShadowReceiver r, vec3 p, LightPlane light)
{
    Walk w;
    w.r = r;
    w.p = p;
    w.light = light;
    w.range = shadowMapData.faces[r.face].depthRange;
    w.faceTexels = int(shadowFaceTexels());
    w.origin = ivec2(int(r.face % 3u), int(r.face / 3u)) * w.faceTexels;
    w.layer = 0;
    w.stride = 1;
    w.mssmBase = 0;
    w.sum = 0.0;
    w.fetches = 0;
#if LAYERS > 1
    w.hidden = lightSamplesFilled(false);
#endif
    return w;
}

// Step 1 and step 5: the receiver's kernel k (cells, inclusive); V when the kernel
// decides it (1: nothing nearer than the receiver anywhere in it; 0: everything nearer,
// so no contour and the centre occluded: umbra), -1 when its contour must be walked.
float receiverKernel(inout Walk w, out ivec4 k)
{
    // The kernel is the whole region that can hide the light (at most the face); the
    // cap bounds the walk, not the region: a kernel wider than the cap is walked on the
    // coarse grid of the least power-of-two stride that fits it in the cap.
    int cap = max(pc.maxKernel, 1);
    int whole = 2 * w.faceTexels;
    float wp = axisDistance(w.r.face, w.p, w.range);
    ivec2 centreCell = clamp(ivec2(floor(w.r.uv * float(w.faceTexels) - 0.5)), ivec2(0), ivec2(w.faceTexels - 1));
    k = kernelAt(w, w.range.x, wp, centreCell, whole);
    vec2 depths = kernelRange(w, k);
    [[unroll]] for (int i = 0; i < kKernelRefinements; ++i) {
        // The nearest sample of the kernel (largest NDC depth) bounds the occluders.
        float nearest = shadowDistanceInRange(w.range, depths.y);
        k = kernelAt(w, max(nearest, w.range.x), wp, centreCell, whole);
        depths = kernelRange(w, k);
    }
    // The stride is at most the MSSM's top node (the hierarchical walk's leaves are its
    // nodes) and 2^kMaxRefinements; a kernel wider than the cap at that stride is cut to
    // it around the receiver, as the cap alone cut every kernel before.
    int side = max(k.z - k.x, k.w - k.y) + 1;
    int most = 1 << min(kMaxRefinements, pc.levels - 1);
    w.stride = 1;
    [[dont_unroll]] while ((side + w.stride - 1) / w.stride > cap && w.stride < most) w.stride *= 2;
    int reach = cap * w.stride;
    k = ivec4(max(k.xy, centreCell - reach / 2), min(k.zw, centreCell + (reach - 1 - reach / 2)));
    vec2 reference = referenceRange(w, k.xy, min(k.zw + 1, ivec2(w.faceTexels - 1)));
    if (depths.x > reference.y) return 0.0;
    if (depths.y <= reference.x) return 1.0;
    return -1.0;
}

// The kernel's side in texels (the debug image).
float kernelSide(ivec4 k)
{
    return float(max(k.z - k.x, k.w - k.y) + 1);
}

// Step 3's end: V from the receiver's sum of edges and whether the light's centre is
// hidden from it (centreOccluded).
float contourVisibility(Walk w, bool centre)
{
    // The map's (u, v) turn the same way as the light's (t1, t2) as the receiver
    // projects one onto the other where the patch and the plane face the receiver
    // alike (both normals against the ray towards the light, or both along it).
    FaceFrame f = bp.faces[w.r.face];
    vec3 mapNormal = cross(f.baseU.xyz + f.dirU.xyz, f.baseV.xyz + f.dirV.xyz);
#if SHADOW_LIGHT_TYPE == 0
    vec3 towards = w.light.normal;
#else
    vec3 towards = w.light.centre - w.p;
#endif
    float orientation = sign(dot(mapNormal, towards)) * sign(dot(cross(w.light.t1, w.light.t2), towards));
    float occluded = (centre ? w.light.area : 0.0) - orientation * w.sum;
    return 1.0 - occluded / w.light.area;
}

// One depth layer's visibility for the receiver (light.area > 0): its own kernel (eq. 8:
// the layer's nearest occluder bounds it), its contour and V. With LAYERS > 1, `hidden`:
// the light samples its contour hides. `walked`: the kernel did not decide.
float layerVisibility(ShadowReceiver r, vec3 p, LightPlane light, int layer, inout float kernelTexels,
                      inout int fetches, inout bool walked, out Walk w)
{
    w = startWalk(r, p, light);
    w.layer = layer;
    w.mssmBase = layer * pc.levels;
    ivec4 k;
    float v = receiverKernel(w, k);
    kernelTexels = max(kernelTexels, kernelSide(k));
    if (v < 0.0) {
        walked = true;
        bool centre = centreOccluded(w);
#if LAYERS > 1
        w.hidden = lightSamplesFilled(centre);
#endif
        walkKernel(w, k, pc.levels);
        v = contourVisibility(w, centre);
    }
#if LAYERS > 1
    else {
        w.hidden = lightSamplesFilled(v == 0.0);
    }
#endif
    fetches += w.fetches;
    return v;
}

// The whole per-receiver visibility (light.area > 0); `walked`: a kernel did not decide.
// With LAYERS 2 the light is hidden by the union of what either layer hides: each
// layer's area exactly (radial integration) less their overlap, the second's area times
// the fraction of the light samples it hides that the first hides too
// (light_samples.glsl). Where the second hides nothing, nothing the first hides, or only
// what the first hides (a closed caster's far side behind its near side), that is
// exact; the samples' error enters only where the two overlap in part.
float backprojectionVisibility(ShadowReceiver r, vec3 p, LightPlane light, out float kernelTexels, out int fetches,
                               out bool walked)
{
    kernelTexels = 0.0;
    fetches = 0;
    walked = false;
    Walk w;
    float v = layerVisibility(r, p, light, 0, kernelTexels, fetches, walked, w);
#if LAYERS > 1
    // The first layer hiding all of the light (umbra) leaves nothing to add.
    if (v > 0.0) {
        LightSamples first = w.hidden;
        float v2 = layerVisibility(r, p, light, 1, kernelTexels, fetches, walked, w);
        LightSamples on = lightSamplesOn(light.halfSize, light.disk);
        uint both = lightSamplesCountBoth(first, w.hidden, on), second = lightSamplesCountBoth(w.hidden, on, on);
        float hidden1 = 1.0 - clamp(v, 0.0, 1.0), hidden2 = 1.0 - clamp(v2, 0.0, 1.0);
        // The overlap is at most the lesser layer's hidden part.
        float overlap = min(hidden2 * float(both) / float(max(second, 1u)), hidden1);
        v = clamp(1.0 - (hidden1 + hidden2 - overlap), 0.0, 1.0);
    }
#endif
    return v;
}
#endif
