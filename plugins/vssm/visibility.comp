#version 460
// Variance soft shadow mapping (Yang, Dong, Feng, Seidel, Kautz 2010; README.md next to
// this file), per G-buffer pixel, after the depth map, its summed-area table of moments
// (sat.glsl) and its min-max hierarchy (hsm.glsl) (paper Algorithm 1, L6-L20):
//   1. the blocker search kernel w_i from the light's size and the receiver's distance
//      (as PCSS, common/penumbra_estimate.glsl);
//   2. the HSM's min and max over w_i: every texel behind the receiver -> lit, every one
//      in front -> umbra (L8-L10);
//   3. the average blocker depth by eq. 4, z_occ = (z_avg - P t) / (1 - P) with
//      Chebyshev's P = P(x >= t), over sub-kernels of w_i (BLOCKER_SUBDIVISION);
//   4. the penumbra kernel w_p from z_occ (L16); a blocker within contact_epsilon of the
//      receiver gets 3 x 3 jittered bilinear PCF instead (§6.4);
//   5. the visibility over sub-kernels of w_p (FILTER_SUBDIVISION): Chebyshev's bound
//      where a sub-kernel's mean lies in front of the receiver, lit where it lies behind
//      with a variance below lit_variance, else (the "non-planarity" case, §5) smaller
//      sub-kernels or, at the finest, 2 x 2 PCF (Algorithm 2). The quad-tree also splits
//      nodes in front that straddle the receiver, takes nodes wholly in front as all
//      blockers, and bounds its leaves by Markov too (markovBound; README.md, "The
//      quad-tree's rule").
//
// Subdivision (defines BLOCKER_SUBDIVISION and FILTER_SUBDIVISION, vssm.cpp):
//   0 none: the whole kernel is one box and a non-planar one counts as lit (SAVSM-like,
//     the incorrectly-lit case the paper removes)
//   1 uniform: m x m (or n x n) equal sub-kernels, non-planar ones by 2 x 2 PCF (§5.2)
//   2 adaptive: a quad-tree of height H over the kernel, walked without a stack in
//     linear order (child and next computed from a node's level and Morton index, which
//     is what Bunnell's precomputed pointers encode; §5.3)
//
// Depths are the normalised t of shadow_map.glsl (0 at the light's near plane, 1 at its
// far plane): larger is farther. The reference each sub-kernel is compared with is the
// receiver's depth, or with RECEIVER_BIAS 2 its plane's depth at the sub-kernel's centre
// plus the rounding margin (common/shadow_receiver.glsl): the mean of a tilted receiver's
// own surface over a sub-kernel is its plane's depth at the centre, so a wide kernel on a
// tilted receiver does not find the receiver itself as a blocker. (The paper compares
// with the receiver's own depth t everywhere; with RECEIVER_BIAS 0 so does this, and the
// rasterizer's slope bias is all there is.) Chebyshev's bound is taken per sub-kernel,
// with that sub-kernel's reference, rather than once over the pooled moments of all
// normal sub-kernels (eq. 5): each bound holds on its own, and a pooled one would mix
// sub-kernels compared with different references.
//
// With DEBUG_IMAGES (the debug_views pass, which the graph runs only when one of its
// images is requested: vssm.cpp) the same work writes, instead of V, the pixel's penumbra
// kernel half-width / max_filter_radius (kernelOut), its class (classificationOut: lit 1,
// non-planar 0.75, penumbra 0.5, contact 0.25, umbra 0) and the sub-kernels it visited /
// the most possible (subkernelsOut); 0 where there is no geometry.
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

#define GBUFFER_BINDING 8  // gDepth, gNormal, GBufferCamera: plugin::bindGBuffer
#include "common/gbuffer.glsl"
#include "common/sampling.glsl"
#include "common/visibility.glsl"

#ifndef RECEIVER_BIAS
#define RECEIVER_BIAS 2
#endif
#ifndef BLOCKER_SUBDIVISION
#define BLOCKER_SUBDIVISION 1
#endif
#ifndef FILTER_SUBDIVISION
#define FILTER_SUBDIVISION 2
#endif
#define SUBDIVISION_NONE 0
#define SUBDIVISION_UNIFORM 1
#define SUBDIVISION_ADAPTIVE 2

layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 1) uniform sampler2DShadow shadowCompare;  // nearest, GREATER_OR_EQUAL
#ifdef DEBUG_IMAGES
layout(binding = 11, r32f) uniform writeonly image2D kernelOut;
layout(binding = 12, r32f) uniform writeonly image2D classificationOut;
layout(binding = 13, r32f) uniform writeonly image2D subkernelsOut;
#define OUTPUT_SIZE imageSize(kernelOut)
#else
layout(binding = 2, VISIBILITY_FORMAT) uniform writeonly image2D visibilityOut;
#define OUTPUT_SIZE imageSize(visibilityOut)
#endif
layout(binding = 5) uniform sampler2D shadowDepth;  // the same map, raw depths

#define SAT_BINDING 6
#define SAT_QUALIFIER readonly
#define SAT_READ_ONLY
#include "sat.glsl"

#define SHADOW_MAP_BINDING 3
#define SHADOW_RECEIVER_BIAS RECEIVER_BIAS
#include "common/shadow_receiver.glsl"
#include "common/penumbra_estimate.glsl"

float hsmLevel0(ivec2 texel) { return shadowLinearDepth(shadowFaceOfTexel(texel), texelFetch(shadowDepth, texel, 0).r); }

#define HSM_BINDING 7
#define HSM_QUALIFIER readonly
#include "hsm.glsl"

layout(push_constant) uniform Push {
    ivec2 atlasSize;        // the map's texels (all faces)
    float lightSize;        // render::softShadowLightSize
    float maxSearchTexels;  // clamps of the kernels' half-widths
    float maxFilterTexels;
    float sceneRadius;      // r: the scene's bounding radius, world units
    float litVariance;      // Threshold / r^2 (§6.5), see litVarianceT
    float contactEpsilon;   // epsilon / r (§6.4)
    int blockerSubdivisions;  // m (uniform)
    int filterSubdivisions;   // n (uniform)
    int treeHeight;           // H (adaptive)
    float subkernelScale;     // 1 / the most sub-kernels a pixel can visit (DEBUG_IMAGES)
    float ownShape;           // 1: the light's own shape (penumbra_estimate.glsl shadowLightExtent); 0: a square
} pc;

// Per-pixel classification (DEBUG_IMAGES: classificationOut shows these values).
const float kClassLit = 1.0;         // the HSM, or no blocker found
const float kClassUmbra = 0.0;       // the HSM
const float kClassPenumbra = 0.5;    // Chebyshev over every sub-kernel
const float kClassNonPlanar = 0.75;  // some sub-kernel needed PCF
const float kClassContact = 0.25;    // blocker within contact_epsilon: PCF

// The pixel's receiver and its face, shared by the helpers below.
ShadowReceiver gReceiver;
float gFaceTexels;
vec2 gFaceOrigin;    // the face's first texel in the atlas
float gLitVariance;  // Threshold in t^2
uint gVisited;       // sub-kernels looked at
bool gUsedPcf;

// The moments over [lo, hi) in texels of the receiver's face, cut to the face.
SatMoments faceBox(vec2 lo, vec2 hi)
{
    lo = clamp(lo, vec2(0.0), vec2(gFaceTexels));
    hi = clamp(hi, vec2(0.0), vec2(gFaceTexels));
    return satBox(gFaceOrigin + lo, gFaceOrigin + hi, pc.atlasSize);
}

// The depth t a texel at face texel position `at` is compared with (see the top).
float referenceT(vec2 at)
{
    return shadowLinearDepth(gReceiver.face, shadowPlaneDepth(gReceiver, at / gFaceTexels));
}

// Chebyshev's one-tailed bound P(x >= t) for moments with mean < t (eq. 1): the
// fraction of the box at or behind t. t - mean > 0, so the denominator is positive.
float chebyshev(SatMoments m, float t)
{
    float d = t - m.mean;
    return m.variance / (m.variance + d * d);
}

// The offset, in texels, from the receiver to face texel position `at`.
vec2 offsetTo(vec2 at) { return at - gReceiver.uv * gFaceTexels; }

// The HSM's min and max of t over the face texels [lo, hi) (cut to the face), and the
// least and largest reference over it (at its corners: the plane's depth is monotonic
// along each axis). A node whose every texel lies in front of every reference there is
// all blockers; step 2's early-out is this test on the whole search kernel.
struct NodeDepths {
    vec2 range;      // (min t, max t) of the texels, conservative (hsmRange)
    vec2 reference;  // (least, largest) reference
};

NodeDepths nodeDepths(vec2 lo, vec2 hi)
{
    vec2 cutLo = clamp(lo, vec2(0.0), vec2(gFaceTexels)), cutHi = clamp(hi, vec2(0.0), vec2(gFaceTexels));
    ivec2 first = ivec2(gFaceOrigin) + ivec2(floor(cutLo));
    ivec2 last = max(ivec2(gFaceOrigin) + ivec2(ceil(cutHi)) - 1, first);
    float t00 = referenceT(cutLo), t11 = referenceT(cutHi);
    float t10 = referenceT(vec2(cutHi.x, cutLo.y)), t01 = referenceT(vec2(cutLo.x, cutHi.y));
    return NodeDepths(hsmRange(first, last, pc.atlasSize),
                      vec2(min(min(t00, t11), min(t10, t01)), max(max(t00, t11), max(t10, t01))));
}

// The quad-tree's own rule for a node in front of the receiver on average (mean < t),
// beyond the paper's Algorithm 2, which hands every such node to Chebyshev: the bound
// P = σ² / (σ² + (t - μ)²) is loose wherever the node's depths spread widely, as under a
// blocker tilted against the light (its depth ramps across the kernel) or where the
// kernel covers a blocker and the ground beside it. With the node's HSM range:
//   - every texel in front of every reference over the node: all blockers (exact);
//   - the range straddling the receiver, not a leaf: split (the filter), or split where
//     eq. 4 would put the blockers nearer the light than the nearest texel (the search);
//   - else the tighter of Chebyshev's bound and Markov's, below.
// Markov's inequality on x - z_min >= 0: μ - z_min >= (t - z_min) P(x >= t), so
// P(x >= t) <= (μ - z_min) / (t - z_min), a valid bound that is tight where the blockers
// lie close to the node's nearest texel and far in front of the receiver; t > μ >= z_min
// here, so the division is by more than 0 (guarded all the same).
float markovBound(SatMoments m, float t, float zMin)
{
    return clamp((m.mean - zMin) / max(t - zMin, 1e-12), 0.0, 1.0);
}

// ---- Blocker estimate (step 3) ------------------------------------------------------

struct Blockers {
    float area;      // the area of the blocking texels found
    float depthSum;  // the sum of their depths t, times area
};

// One sub-kernel [lo, hi) with moments m: adds its blockers, or asks to be split (descend) when it is
// non-planar and not a leaf. `pcfLeaves`: a non-planar leaf is sampled by 2 x 2 PCF; else
// it counts as lit (subdivision none).
void addBlockerNode(SatMoments m, vec2 lo, vec2 hi, bool leaf, bool pcfLeaves, bool tree, inout Blockers b,
                    out bool descend)
{
    descend = false;
    ++gVisited;
    if (!(m.area > 0.0)) return;
    float t = referenceT(0.5 * (lo + hi));
    // The quad-tree's rule (markovBound above): a straddling node is split, and so is one
    // where eq. 4 would put the blockers nearer the light than its nearest texel. (Only
    // the latter cost less but left 42 deep-umbra pixels lit under a 60° light.)
    NodeDepths depths = NodeDepths(vec2(0.0, 1.0), vec2(t));
    if (tree && m.mean < t) {
        depths = nodeDepths(lo, hi);
        if (depths.range.y < depths.reference.x) {  // all blockers: their mean depth is the box's
            b.area += m.area;
            b.depthSum += m.mean * m.area;
            return;
        }
    }
    if (m.mean < t) {
        // Eq. 4 with z_unocc = t: the blockers are the share 1 - P of the box, at mean
        // depth (z_avg - P t) / (1 - P). P -> 1 leaves no blocker worth the division.
        // Eq. 4 puts them nearer the light than the node's nearest texel exactly where
        // Chebyshev's P exceeds the Markov bound of the HSM's min.
        float p = chebyshev(m, t);
        float markov = tree ? markovBound(m, t, depths.range.x) : 1.0;
        if (tree && !leaf && (p > markov || depths.range.x < depths.reference.y)) {
            descend = true;
            return;
        }
        p = min(p, markov);
        float blocking = 1.0 - p;
        float estimate = (m.mean - p * t) / max(blocking, 1e-6);
        if (blocking > 1e-6) {
            float zOcc = clamp(estimate, depths.range.x, t);
            b.area += blocking * m.area;
            b.depthSum += zOcc * blocking * m.area;
        }
        return;
    }
    if (m.variance < gLitVariance) return;  // behind the receiver and nearly flat: lit
    if (!leaf) {
        descend = true;
        return;
    }
    if (!pcfLeaves) return;
    // Non-planar leaf: 2 x 2 depth taps at the quarters' centres.
    gUsedPcf = true;
    for (int i = 0; i < 4; ++i) {
        vec2 at = mix(lo, hi, vec2(0.25 + 0.5 * float(i & 1), 0.25 + 0.5 * float(i >> 1)));
        vec2 uv = shadowTapUv(gReceiver, offsetTo(at));
        float depth = textureLod(shadowDepth, shadowAtlasUv(gReceiver.face, uv), 0.0).r;
        if (depth > shadowReferenceDepth(gReceiver, uv)) {  // reversed-Z: nearer the light
            b.area += 0.25 * m.area;
            b.depthSum += 0.25 * m.area * shadowLinearDepth(gReceiver.face, depth);
        }
    }
}

// ---- Visibility (step 5) ------------------------------------------------------------

struct Lit {
    float area;     // the kernel's area looked at
    float litArea;  // of which lit
};

void addFilterNode(SatMoments m, vec2 lo, vec2 hi, bool leaf, bool pcfLeaves, bool tree, inout Lit f,
                   out bool descend)
{
    descend = false;
    ++gVisited;
    if (!(m.area > 0.0)) return;
    float t = referenceT(0.5 * (lo + hi));
    if (m.mean < t) {
        float p = chebyshev(m, t);
        if (tree) {
            NodeDepths n = nodeDepths(lo, hi);
            if (n.range.y < n.reference.x) {  // all blockers: none of it lit
                f.area += m.area;
                return;
            }
            if (!leaf && n.range.x < n.reference.y) {  // straddles the receiver: split
                descend = true;
                return;
            }
            p = min(p, markovBound(m, t, n.range.x));
        }
        f.area += m.area;
        f.litArea += p * m.area;
        return;
    }
    if (m.variance < gLitVariance || !pcfLeaves) {
        f.area += m.area;
        f.litArea += m.area;
        return;
    }
    if (!leaf) {
        descend = true;
        return;
    }
    gUsedPcf = true;
    float lit = 0.0;
    for (int i = 0; i < 4; ++i)
        lit += shadowCompareTap(shadowCompare, gReceiver,
                                offsetTo(mix(lo, hi, vec2(0.25 + 0.5 * float(i & 1), 0.25 + 0.5 * float(i >> 1)))));
    f.area += m.area;
    f.litArea += 0.25 * lit * m.area;
}

// ---- Traversals ---------------------------------------------------------------------

// Morton index -> cell (x, y) of its level.
ivec2 mortonCell(uint index)
{
    ivec2 cell = ivec2(0);
    for (int bit = 0; bit < 8; ++bit) {
        cell.x |= int((index >> (2 * bit)) & 1u) << bit;
        cell.y |= int((index >> (2 * bit + 1)) & 1u) << bit;
    }
    return cell;
}

// A point of the n x n lattice over the kernel [lo, hi) (face texels), cut to the face,
// in atlas texels.
vec2 latticePoint(vec2 lo, vec2 hi, int i, int j, int n)
{
    return gFaceOrigin + clamp(mix(lo, hi, vec2(i, j) / float(n)), vec2(0.0), vec2(gFaceTexels));
}

const int kMaxUniformSubdivisions = 16;  // vssm.cpp blocker_ and filter_subdivisions
dvec2 gLatticeRow[kMaxUniformSubdivisions + 1];

// Visits the kernel [lo, hi) as `mode` says; NODE(m, lo, hi, leaf, descend) adds one node
// with moments m. Uniform: the n x n sub-kernels share their corners, so the table is
// read at the (n + 1)^2 lattice points once (four entries each, satIntegral), a row at a
// time, instead of four corners per sub-kernel.
#define TRAVERSE(mode, count, lo, hi, NODE)                                                 \
    if (mode == SUBDIVISION_NONE) {                                                         \
        bool descend;                                                                       \
        NODE(faceBox(lo, hi), lo, hi, true, descend);                                       \
    } else if (mode == SUBDIVISION_UNIFORM) {                                               \
        int n = clamp(count, 1, kMaxUniformSubdivisions);                                   \
        u64vec2 base = satCorner(ivec2(floor(latticePoint(lo, hi, 0, 0, n))), pc.atlasSize); \
        for (int i = 0; i <= n; ++i)                                                        \
            gLatticeRow[i] = satIntegral(latticePoint(lo, hi, i, 0, n), base, pc.atlasSize); \
        for (int j = 0; j < n; ++j) {                                                       \
            vec2 a = latticePoint(lo, hi, 0, j + 1, n);                                     \
            dvec2 left = satIntegral(a, base, pc.atlasSize);                                \
            for (int i = 0; i < n; ++i) {                                                   \
                vec2 p0 = latticePoint(lo, hi, i, j, n), p1 = latticePoint(lo, hi, i + 1, j + 1, n); \
                dvec2 right = satIntegral(p1, base, pc.atlasSize);                          \
                dvec2 sum = right - left - gLatticeRow[i + 1] + gLatticeRow[i];             \
                double area = double(p1.x - p0.x) * double(p1.y - p0.y);                    \
                gLatticeRow[i] = left; /* the next row's, column i: box i no longer needs it */ \
                left = right;                                                               \
                bool descend;                                                               \
                NODE(satMoments(satMomentsOfSums(sum, area)), mix(lo, hi, vec2(i, j) / float(n)), \
                     mix(lo, hi, vec2(i + 1, j + 1) / float(n)), true, descend);           \
            }                                                                               \
            gLatticeRow[n] = left;                                                          \
        }                                                                                   \
    } else {                                                                                \
        /* Stackless linear quad-tree walk (Algorithm 2): child = (level + 1, 4 index),     \
           next = the next sibling, or the parent's next after the last sibling. */         \
        int height = clamp(pc.treeHeight, 0, 5);                                            \
        int level = 0;                                                                      \
        uint index = 0u;                                                                    \
        for (;;) {                                                                          \
            vec2 size = (hi - lo) / float(1 << level);                                      \
            vec2 nodeLo = lo + size * vec2(mortonCell(index));                              \
            bool descend;                                                                   \
            NODE(faceBox(nodeLo, nodeLo + size), nodeLo, nodeLo + size, level == height, descend); \
            if (descend) {                                                                  \
                ++level;                                                                    \
                index *= 4u;                                                                \
                continue;                                                                   \
            }                                                                               \
            while (level > 0 && (index & 3u) == 3u) {                                       \
                index >>= 2;                                                                \
                --level;                                                                    \
            }                                                                               \
            if (level == 0) break;                                                          \
            ++index;                                                                        \
        }                                                                                   \
    }

// ---- Contact (§6.4) -----------------------------------------------------------------

// Bilinear PCF at an offset from the receiver: the four texels' compares, each against
// the reference at its own centre, weighted bilinearly.
float bilinearCompare(vec2 offsetTexels)
{
    vec2 p = gReceiver.uv * gFaceTexels + offsetTexels - 0.5;
    vec2 i = floor(p), w = p - i;
    float v00 = shadowCompareTap(shadowCompare, gReceiver, offsetTo(i + vec2(0.5, 0.5)));
    float v10 = shadowCompareTap(shadowCompare, gReceiver, offsetTo(i + vec2(1.5, 0.5)));
    float v01 = shadowCompareTap(shadowCompare, gReceiver, offsetTo(i + vec2(0.5, 1.5)));
    float v11 = shadowCompareTap(shadowCompare, gReceiver, offsetTo(i + vec2(1.5, 1.5)));
    return mix(mix(v00, v10, w.x), mix(v01, v11, w.x), w.y);
}

// 3 x 3 bilinear PCF over the penumbra kernel (half-width `radius` texels), the grid
// rotated per pixel (jittered, Bavoil 2008).
float contactPcf(vec2 radius, ivec2 pixel)
{
    mat2 rotation = poissonRotation(pixel);
    vec2 spacing = 2.0 * radius / 3.0;
    float lit = 0.0;
    for (int j = -1; j <= 1; ++j)
        for (int i = -1; i <= 1; ++i) lit += bilinearCompare(rotation * (vec2(i, j) * spacing));
    return lit / 9.0;
}

// ---- The pixel ----------------------------------------------------------------------

struct Result {
    float v;
    float kernelTexels;  // the penumbra kernel's half-width (0: decided before it)
    float classification;
};

Result vssmVisibility(ivec2 pixel, vec3 position)
{
    Result res = Result(1.0, 0.0, kClassLit);
    ShadowFace face = shadowMapData.faces[gReceiver.face];
    // A light of size 0 (or a degenerate map) casts a hard shadow: exactly hard's one
    // nearest compare.
    if (!(pc.lightSize > 0.0) || !(face.texel.x > 0.0)) {
        res.v = shadowCompareTap(shadowCompare, gReceiver, vec2(0.0));
        res.classification = res.v > 0.5 ? kClassLit : kClassUmbra;
        return res;
    }
    // The scene-relative thresholds in units of t (the face's depth range; ShadowMap
    // keeps it positive).
    float depthRange = face.depthRange.y - face.depthRange.x;
    float radiusT = pc.sceneRadius / depthRange;
    gLitVariance = pc.litVariance * radiusT * radiusT;
    float contactT = pc.contactEpsilon * radiusT;

    float dReceiver = shadowDistance(gReceiver.face, gReceiver.depth);
    vec2 centre = gReceiver.uv * gFaceTexels;
    float tReceiver = referenceT(centre);

    // 1-2. The search kernel and the HSM's early-out: nodeDepths over the whole kernel.
    vec2 lightExtent = shadowLightExtent(face, position, pc.lightSize, pc.ownShape > 0.5);
    vec2 search = max(shadowSearchRadiusTexels(face, lightExtent, dReceiver, pc.maxSearchTexels), vec2(0.5));
    vec2 lo = centre - search, hi = centre + search;
    vec2 cutLo = clamp(lo, vec2(0.0), vec2(gFaceTexels)), cutHi = clamp(hi, vec2(0.0), vec2(gFaceTexels));
    NodeDepths kernel = nodeDepths(lo, hi);
    vec2 range = kernel.range;
    if (range.x >= kernel.reference.y) return res;  // every texel behind the receiver: lit
    if (range.y < kernel.reference.x) {              // every texel in front: umbra
        res.v = 0.0;
        res.classification = kClassUmbra;
        return res;
    }

    // 3. The average blocker depth.
    Blockers b = Blockers(0.0, 0.0);
#define BLOCKER_NODE(m, nlo, nhi, leaf, descend) \
    addBlockerNode(m, nlo, nhi, leaf, BLOCKER_SUBDIVISION != SUBDIVISION_NONE,              \
                   BLOCKER_SUBDIVISION == SUBDIVISION_ADAPTIVE, b, descend)
    TRAVERSE(BLOCKER_SUBDIVISION, pc.blockerSubdivisions, lo, hi, BLOCKER_NODE)
    float kernelArea = (cutHi.x - cutLo.x) * (cutHi.y - cutLo.y);
    if (!(b.area > 1e-4 * kernelArea)) return res;  // no blocker: lit
    // Clamped into [z_min, t]: eq. 4 extrapolates, and the HSM bounds what is there.
    float zOcc = clamp(b.depthSum / b.area, range.x, tReceiver);

    // 4. The penumbra kernel.
    float dBlocker = face.depthRange.x + zOcc * depthRange;
    vec2 radius = max(shadowFilterRadiusTexels(face, lightExtent, dReceiver, dBlocker, pc.maxFilterTexels), vec2(0.5));
    res.kernelTexels = max(radius.x, radius.y);
    if (tReceiver - zOcc < contactT) {
        res.v = contactPcf(radius, pixel);
        res.classification = kClassContact;
        return res;
    }

    // 5. The visibility over it.
    Lit f = Lit(0.0, 0.0);
    vec2 flo = centre - radius, fhi = centre + radius;
#define FILTER_NODE(m, nlo, nhi, leaf, descend) \
    addFilterNode(m, nlo, nhi, leaf, FILTER_SUBDIVISION != SUBDIVISION_NONE,                \
                  FILTER_SUBDIVISION == SUBDIVISION_ADAPTIVE, f, descend)
    TRAVERSE(FILTER_SUBDIVISION, pc.filterSubdivisions, flo, fhi, FILTER_NODE)
    res.v = f.area > 0.0 ? f.litArea / f.area : 1.0;
    res.classification = gUsedPcf ? kClassNonPlanar : kClassPenumbra;
    return res;
}

// Straight-line up to the technique's own traversal: every pixel runs the same code and
// the results are selected at the end (common/shadow_map.glsl: uniform loads).
void main()
{
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = OUTPUT_SIZE;
    bool inImage = all(lessThan(pixel, size));
    pixel = min(pixel, size - 1);
    float maxFilterTexels = pc.maxFilterTexels;
    float subkernelScale = pc.subkernelScale;

    vec4 position = gbufferPosition(pixel);
    gVisited = 0u;
    gUsedPcf = false;
    bool inMap = makeShadowReceiver(pixel, position.xyz, 0.0, gReceiver);
    gFaceTexels = shadowFaceTexels();
    gFaceOrigin = shadowFaceCount() == 6u ? vec2(float(gReceiver.face % 3u), float(gReceiver.face / 3u)) * gFaceTexels
                                          : vec2(0.0);
    Result res = vssmVisibility(pixel, position.xyz);
    res = inMap ? res : Result(VISIBILITY_NO_GEOMETRY, 0.0, kClassLit);
#ifdef DEBUG_IMAGES
    bool geometry = position.w != 0.0;
    float kernel = geometry ? res.kernelTexels / max(maxFilterTexels, 0.5) : 0.0;
    float classification = geometry ? res.classification : 0.0;
    float subkernels = geometry && inMap ? float(gVisited) * subkernelScale : 0.0;  // outside the map: none looked at
    if (inImage) {
        imageStore(kernelOut, pixel, vec4(kernel));
        imageStore(classificationOut, pixel, vec4(classification));
        imageStore(subkernelsOut, pixel, vec4(subkernels));
    }
#else
    float v = shadowVisibilityAboveHorizon(res.v, position.xyz, gbufferNormal(pixel));
    v = position.w != 0.0 ? v : VISIBILITY_NO_GEOMETRY;
    if (inImage) imageStore(visibilityOut, pixel, vec4(sanitizeVisibility(v)));
#endif
}
