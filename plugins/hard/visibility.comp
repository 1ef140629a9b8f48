#version 460
// Hard shadow-map lookup for one light: each G-buffer position is projected into the
// light's depth map and compared, and the fraction of passing compares is written as
// V_l (shaders/common/visibility.glsl).
//
// The map is reversed-Z: a receiver is lit where its light-space depth is >= the stored
// caster depth (the sampler's compareOp GREATER_OR_EQUAL), and "towards the light" is
// towards larger depth. Spot and directional lights have one map; point, rect and disk
// lights six cube faces packed 3 x 2 in one atlas, the face chosen by the dominant axis
// of the direction from the light (render/Projection.h builds them in that order).
//
// The variant is chosen by defines (plugins/hard/visibility_pass.h sets them):
//   FILTER         0 none: one nearest compare
//                  1 pcf: PCF_KERNEL x PCF_KERNEL nearest compares at texel spacing
//                  2 poisson: POISSON_SAMPLES compares on a disk of filterRadiusTexels,
//                    rotated per pixel
//                  3 bilinear: one 2 x 2 compare with bilinear weights
//   RECEIVER_BIAS  0 none (constant and slope-scaled bias are the rasterizer's)
//                  1 normal offset
//                  2 receiver plane depth bias
#include "common/gbuffer.glsl"
#include "common/visibility.glsl"

#define FILTER_NONE 0
#define FILTER_PCF 1
#define FILTER_POISSON 2
#define FILTER_BILINEAR 3
#define RECEIVER_BIAS_NONE 0
#define RECEIVER_BIAS_NORMAL_OFFSET 1
#define RECEIVER_BIAS_PLANE 2

// The plugin always defines both (plugins/hard/visibility_pass.h); compiled on its own
// (a shader tool, the engine's every-shader test) this is the default variant.
#ifndef FILTER
#define FILTER FILTER_NONE
#endif
#ifndef RECEIVER_BIAS
#define RECEIVER_BIAS RECEIVER_BIAS_NONE
#endif
#if FILTER == FILTER_PCF && !defined(PCF_KERNEL)
#error FILTER 1 (pcf) needs PCF_KERNEL
#endif
#if FILTER == FILTER_POISSON
#ifndef POISSON_SAMPLES
#error FILTER 2 (poisson) needs POISSON_SAMPLES
#endif
#include "poisson_disk.glsl"
#endif

layout(local_size_x = 8, local_size_y = 8) in;

struct Face {
    mat4 viewProj;  // world -> clip, reversed-Z
    vec4 texel;     // x: world size of one texel per unit of clip w
};

layout(binding = 0, GBUFFER_POSITION_FORMAT) uniform readonly image2D gPosition;
layout(binding = 1) uniform sampler2DShadow shadowMap;
layout(binding = 2, VISIBILITY_FORMAT) uniform writeonly image2D visibilityOut;
layout(std430, binding = 3) readonly buffer Faces { Face faces[]; };
#if RECEIVER_BIAS != RECEIVER_BIAS_NONE
layout(binding = 4, GBUFFER_NORMAL_FORMAT) uniform readonly image2D gNormal;
#endif

layout(push_constant) uniform Push {
    vec4 light;                // xyz position (w = 1) or unit direction towards the light (w = 0)
    uint faceCount;            // 1, or 6 cube faces in a 3 x 2 atlas
    float faceTexels;          // texels per face side
    float normalOffsetTexels;  // RECEIVER_BIAS 1
    float filterRadiusTexels;  // FILTER 2
} pc;

// A receiver as the map sees it.
struct Receiver {
    uint face;
    vec2 uv;      // in the face, [0, 1]^2
    float depth;  // reversed-Z NDC
#if RECEIVER_BIAS == RECEIVER_BIAS_PLANE
    vec2 dDepthDUv;  // the receiver's plane: depth(uv') = depth + dot(dDepthDUv, uv' - uv)
    float epsilon;   // what remains after the plane: rounding (see receiverPlane)
#endif
};

// Face order +X -X +Y -Y +Z -Z, as render/Projection.cpp builds them.
uint cubeFace(vec3 d)
{
    vec3 a = abs(d);
    if (a.x >= a.y && a.x >= a.z) return d.x > 0.0 ? 0u : 1u;
    if (a.y >= a.z) return d.y > 0.0 ? 2u : 3u;
    return d.z > 0.0 ? 4u : 5u;
}

uint faceOf(vec3 world) { return pc.faceCount == 6u ? cubeFace(world - pc.light.xyz) : 0u; }

// Face uv, depth and clip w of a world point. False behind the light (w <= 0: the
// division would mirror the point or blow up) and for anything not finite.
bool project(uint face, vec3 world, out vec3 uvDepth, out float w)
{
    vec4 clip = faces[face].viewProj * vec4(world, 1.0);
    w = clip.w;
    uvDepth = vec3(0.0);
    if (!(clip.w > 0.0)) return false;
    uvDepth = vec3(clip.xy / clip.w * 0.5 + 0.5, clip.z / clip.w);
    return !any(isinf(uvDepth)) && !any(isnan(uvDepth));
}

// Unit vector from `p` towards the light; zero when p is at the light.
vec3 towardsLight(vec3 p)
{
    if (pc.light.w == 0.0) return pc.light.xyz;
    vec3 d = pc.light.xyz - p;
    float len = length(d);
    return len > 0.0 ? d / len : vec3(0.0);
}

vec2 atlasUv(uint face, vec2 faceUv)
{
    vec2 grid = pc.faceCount == 6u ? vec2(3.0, 2.0) : vec2(1.0);
    return (vec2(face % 3u, face / 3u) + faceUv) / grid;
}

// Keeps a tap `marginTexels` inside its face: the next cell of the atlas is another
// cube face, not the continuation of this one. Taps beyond a cube edge read the face's
// border texels instead of the adjacent face (an error confined to a filter radius
// around cube edges); for a one-face map this is the clamp to the map's edge.
vec2 clampToFace(vec2 uv, float marginTexels)
{
    float margin = marginTexels / pc.faceTexels;
    return clamp(uv, vec2(margin), vec2(1.0 - margin));
}

float referenceDepth(Receiver r, vec2 uv)
{
#if RECEIVER_BIAS == RECEIVER_BIAS_PLANE
    return r.depth + dot(r.dDepthDUv, uv - r.uv) + r.epsilon;
#else
    return r.depth;
#endif
}

// One nearest-texel compare, `offsetTexels` from the receiver. It samples at the
// texel's centre, which is where the rasterizer evaluated the caster's depth, so a
// receiver plane is evaluated at the same point.
float tap(Receiver r, vec2 offsetTexels)
{
    vec2 uv = clampToFace(r.uv + offsetTexels / pc.faceTexels, 0.5);
    vec2 centre = (floor(uv * pc.faceTexels) + 0.5) / pc.faceTexels;
    return texture(shadowMap, vec3(atlasUv(r.face, centre), referenceDepth(r, centre)));
}

#if FILTER == FILTER_POISSON
// Interleaved gradient noise (Jimenez 2014, "Next Generation Post Processing in Call of
// Duty: Advanced Warfare"): a per-pixel rotation of the disk turns the banding of one
// fixed pattern into fine noise.
float interleavedGradientNoise(vec2 pixel)
{
    return fract(52.9829189 * fract(dot(pixel, vec2(0.06711056, 0.00583715))));
}
#endif

float filteredVisibility(Receiver r, ivec2 pixel)
{
#if FILTER == FILTER_NONE
    return tap(r, vec2(0.0));
#elif FILTER == FILTER_PCF
    // Percentage-closer filtering (Reeves, Salesin, Cook 1987): the fraction of a box of
    // compares, one per texel, centred on the receiver.
    const int h = (PCF_KERNEL - 1) / 2;
    float lit = 0.0;
    for (int y = -h; y <= h; ++y)
        for (int x = -h; x <= h; ++x) lit += tap(r, vec2(x, y));
    return lit / float(PCF_KERNEL * PCF_KERNEL);
#elif FILTER == FILTER_POISSON
    float angle = 6.28318531 * interleavedGradientNoise(vec2(pixel));
    float c = cos(angle), s = sin(angle);
    mat2 rotation = mat2(c, s, -s, c);
    float lit = 0.0;
    for (int i = 0; i < POISSON_SAMPLES; ++i) lit += tap(r, rotation * kPoissonDisk[i] * pc.filterRadiusTexels);
    return lit / float(POISSON_SAMPLES);
#elif FILTER == FILTER_BILINEAR && RECEIVER_BIAS != RECEIVER_BIAS_PLANE
    // The sampler's LINEAR filter with compare: four compares weighted bilinearly in
    // hardware. A one-texel margin keeps the whole 2 x 2 footprint inside the face.
    return texture(shadowMap, vec3(atlasUv(r.face, clampToFace(r.uv, 1.0)), r.depth));
#else
    // Bilinear with receiver plane bias: the same four texels and weights as the
    // hardware filter, but each compared against the plane's depth at its own centre.
    vec2 st = r.uv * pc.faceTexels - 0.5;
    vec2 f = st - floor(st);
    float t00 = tap(r, -f), t10 = tap(r, vec2(1.0, 0.0) - f);
    float t01 = tap(r, vec2(0.0, 1.0) - f), t11 = tap(r, vec2(1.0) - f);
    return mix(mix(t00, t10, f.x), mix(t01, t11, f.x), f.y);
#endif
}

// Left-over error once a receiver-side bias has done its work (fp32 positions, the
// rasterizer's depth interpolation, texel-centre rounding), in texels so that it scales
// with the map.
const float kRoundingTexels = 1.0 / 16.0;
// Beyond 88 degrees between a receiver and the map's iso-depth surface the bias a
// receiver would need grows without bound; shading weights such receivers by N.L ~ 0.
const float kMaxTan = 28.6;  // tan(88 degrees)

#if RECEIVER_BIAS == RECEIVER_BIAS_NORMAL_OFFSET
// The direction in which the map's depth grows fastest at p (towards the light): the
// normal of its iso-depth surface. Orthographic: the light's direction; perspective
// (depth = near / w): the face's backward axis, not the ray to the light.
vec3 depthGradientDirection(uint face, vec3 p)
{
    mat4 m = faces[face].viewProj;
    vec4 clip = m * vec4(p, 1.0);
    // w^2 grad(z / w) = w grad z - z grad w, with w > 0 here.
    vec3 g = clip.w * vec3(m[0][2], m[1][2], m[2][2]) - clip.z * vec3(m[0][3], m[1][3], m[2][3]);
    float len = length(g);
    return len > 0.0 ? g / len : vec3(0.0);
}

// Normal offset (Holbert, "Normal Offset Shadows", GDC 2011): the map is read for a
// point moved off the surface along its normal n. A nearest lookup compares with the
// map up to e = 0.7 texel beside the receiver, on another ray from the light. Across
// such an offset v (perpendicular to the ray) the receiver's plane moves by up to
// |v| tan(theta) along the ray (theta: n to the ray l) and the map's depth, which is
// constant on planes perpendicular to D (the iso-depth normal, at alpha to the ray),
// changes by up to |v| (tan(theta) cos(alpha) + sin(alpha)) in units along D. Moving d
// along n raises the receiver d cos(alpha) / cos(theta) above its plane in the same
// units. So d = k · texel · (sin(theta) + tan(alpha) cos(theta)) leaves a margin of k / e
// times the worst error, for any angle: k >= 0.7 (times the filter's width, which
// hard.cpp applies) is free of self-shadowing. Orthographic maps (alpha = 0) give
// Holbert's sin(theta); a perspective map also needs an offset where a surface faces
// the light off the map's axis. The price: the lookup point moves sideways, so shadows
// shift by up to d on steep receivers.
vec3 offsetAlongNormal(uint face, vec3 p, vec3 n, float texelWorld)
{
    vec3 l = towardsLight(p);
    float cosTheta = min(abs(dot(n, l)), 1.0);
    float cosAlpha = min(abs(dot(l, depthGradientDirection(face, p))), 1.0);
    float sinTheta = sqrt(1.0 - cosTheta * cosTheta);
    float tanAlpha = sqrt(1.0 - cosAlpha * cosAlpha) / max(cosAlpha, 1.0 / kMaxTan);
    float factor = min(sinTheta + tanAlpha * cosTheta, kMaxTan);
    return p + n * (texelWorld * (pc.normalOffsetTexels * factor + kRoundingTexels));
}
#endif

#if RECEIVER_BIAS == RECEIVER_BIAS_PLANE
// Receiver plane depth bias (Isidoro, "Shadow Mapping: GPU-based Tips and Techniques",
// GDC 2006): the receiver's depth is an affine function of light uv over its plane
// (exact for planes, perspective or orthographic: NDC depth is affine in NDC xy over a
// plane), so each tap compares the texel's caster depth with the plane's depth at that
// texel's centre instead of the receiver's own depth. Self-shadowing of planar
// receivers disappears for any filter radius without pushing shadows away from their
// casters.

// Neighbours give the plane of the triangle the map holds, where the receiver is flat
// at the scale of a pixel: each must lie within 0.6 degrees of the receiver's tangent
// plane (the G-buffer normal), the plane through the three must agree with the normal
// within 3 degrees (a neighbour just across an edge can pass the first test), and they
// must be within 4 texels in the map. On a curved receiver they would give a secant
// plane, which a convex surface rises above between the points (self-shadowing): there
// the tangent plane of the G-buffer normal is used instead, which a convex surface
// stays below.
const float kCoplanarSine = 0.01;
const float kPlaneAgreesCosine = 0.9986;
const float kMaxNeighbourTexels = 4.0;

// Of the two neighbours along `axis`, the one that lies on the receiver's surface; at a
// silhouette neither may.
bool surfaceNeighbour(ivec2 pixel, ivec2 axis, vec3 p, vec3 n, out vec3 q)
{
    q = p;
    float best = kCoplanarSine;
    bool found = false;
    ivec2 size = imageSize(gPosition);
    for (int side = -1; side <= 1; side += 2) {
        ivec2 at = pixel + side * axis;
        if (any(lessThan(at, ivec2(0))) || any(greaterThanEqual(at, size))) continue;
        vec4 other = imageLoad(gPosition, at);
        vec3 d = other.xyz - p;
        float len = length(d);
        if (other.w == 0.0 || !(len > 0.0)) continue;
        float offPlane = abs(dot(n, d)) / len;
        if (offPlane < best) {
            best = offPlane;
            q = other.xyz;
            found = true;
        }
    }
    return found;
}

// dDepth/dUv of the plane through the receiver and two more points of it, given as
// (uv, depth) differences a and b: solves [a.xy; b.xy] g = [a.z; b.z]. False when the
// two differences are too short to resolve (below 1/64 texel: fp32 noise), longer than
// `maxTexels`, or nearly parallel in uv (the plane is seen edge-on from the light).
bool solveGradient(vec3 a, vec3 b, float maxTexels, out vec2 g)
{
    g = vec2(0.0);
    float la = length(a.xy), lb = length(b.xy);
    float det = a.x * b.y - a.y * b.x;
    if (!(min(la, lb) * pc.faceTexels > 1.0 / 64.0) || !(max(la, lb) * pc.faceTexels <= maxTexels) ||
        !(abs(det) > 1e-3 * la * lb))
        return false;
    g = vec2(a.z * b.y - a.y * b.z, a.x * b.z - a.z * b.x) / det;
    return !any(isinf(g)) && !any(isnan(g));
}

bool planeAgreesWithNormal(vec3 p, vec3 q1, vec3 q2, vec3 n)
{
    vec3 c = cross(q1 - p, q2 - p);
    float len = length(c);
    return len > 0.0 && abs(dot(c, n)) > kPlaneAgreesCosine * len;
}

bool gradientThrough(uint face, vec3 uvDepth, vec3 q1, vec3 q2, float maxTexels, out vec2 g)
{
    g = vec2(0.0);
    vec3 a, b;
    float wa, wb;
    return project(face, q1, a, wa) && project(face, q2, b, wb) &&
           solveGradient(a - uvDepth, b - uvDepth, maxTexels, g);
}

void receiverPlane(ivec2 pixel, vec3 p, vec3 n, float texelWorld, inout Receiver r)
{
    vec3 uvDepth = vec3(r.uv, r.depth);
    // zStep: the depth gained by moving one texel (its world size here) towards the light.
    float zStep = 0.0;
    vec3 stepped;
    float w;
    if (project(r.face, p + towardsLight(p) * texelWorld, stepped, w)) zStep = max(stepped.z - r.depth, 0.0);

    // The plane through the receiver and its neighbours on the same flat surface;
    // failing that, the tangent plane of the G-buffer normal through two points a texel
    // away.
    vec2 g = vec2(0.0);
    vec3 q1, q2;
    bool fromNeighbours = surfaceNeighbour(pixel, ivec2(1, 0), p, n, q1) &&
                          surfaceNeighbour(pixel, ivec2(0, 1), p, n, q2) && planeAgreesWithNormal(p, q1, q2, n) &&
                          gradientThrough(r.face, uvDepth, q1, q2, kMaxNeighbourTexels, g);
    if (!fromNeighbours && dot(n, n) > 0.0) {
        vec3 t1 = normalize(cross(n, abs(n.y) < 0.9 ? vec3(0.0, 1.0, 0.0) : vec3(1.0, 0.0, 0.0)));
        vec3 t2 = cross(n, t1);
        gradientThrough(r.face, uvDepth, p + t1 * texelWorld, p + t2 * texelWorld, kMaxTan, g);
    }
    // |g| per texel is at most (tan(theta) + tan(alpha)) · zStep (theta: the plane's
    // normal to the ray, alpha: the ray to the map's iso-depth normal; see
    // offsetAlongNormal): clamped where that passes tan(88 degrees).
    float perTexel = length(g) / pc.faceTexels;
    float maxPerTexel = kMaxTan * zStep;
    if (perTexel > maxPerTexel) {
        g *= maxPerTexel / perTexel;  // perTexel > maxPerTexel >= 0: no division by zero
        perTexel = maxPerTexel;
    }
    r.dDepthDUv = g;
    // The rounding margin: along the light, and along the plane's slope.
    r.epsilon = kRoundingTexels * (zStep + perTexel);
}
#endif

// False where the map has nothing to say (behind the light, outside the map): V = 1
// there by contract, the light's own cone gives zero light in shading.
bool makeReceiver(ivec2 pixel, vec3 p, out Receiver r)
{
    r.face = 0u;
    r.uv = vec2(0.0);
    r.depth = 0.0;
#if RECEIVER_BIAS != RECEIVER_BIAS_NONE
    vec3 n = imageLoad(gNormal, pixel).xyz;
    float nLength = length(n);
    n = nLength > 1e-6 ? n / nLength : vec3(0.0);  // no normal: no receiver-side bias
#endif
    vec3 uvDepth;
    float w;
#if RECEIVER_BIAS == RECEIVER_BIAS_NORMAL_OFFSET
    uint ownFace = faceOf(p);
    if (project(ownFace, p, uvDepth, w)) p = offsetAlongNormal(ownFace, p, n, w * faces[ownFace].texel.x);
#endif
    r.face = faceOf(p);
    if (!project(r.face, p, uvDepth, w)) return false;
    if (any(lessThan(uvDepth.xy, vec2(0.0))) || any(greaterThan(uvDepth.xy, vec2(1.0)))) return false;
    r.uv = uvDepth.xy;
    r.depth = uvDepth.z;
#if RECEIVER_BIAS == RECEIVER_BIAS_PLANE
    r.dDepthDUv = vec2(0.0);
    r.epsilon = 0.0;
    receiverPlane(pixel, p, n, w * faces[r.face].texel.x, r);
#endif
    return true;
}

void main()
{
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(pixel, imageSize(visibilityOut)))) return;

    vec4 position = imageLoad(gPosition, pixel);
    float v = VISIBILITY_NO_GEOMETRY;
    Receiver r;
    if (position.w != 0.0 && makeReceiver(pixel, position.xyz, r)) v = filteredVisibility(r, pixel);
    imageStore(visibilityOut, pixel, vec4(sanitizeVisibility(v)));
}
