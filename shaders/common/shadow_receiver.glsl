// A G-buffer surface point as a shadow map sees it (common/shadow_map.glsl): the face it
// falls in, its uv and depth there, and the receiver-side bias that keeps it from
// shadowing itself. Shared by the techniques that compare depths (hard, pcss).
//
// The including shader defines, before including this file:
//   SHADOW_RECEIVER_BIAS  0 none (a constant or slope-scaled bias is the rasterizer's)
//                         1 normal offset (Holbert 2011)
//                         2 receiver plane depth bias (Isidoro 2006)
//                         (render::ReceiverBias in render/ShadowMap.h)
// and includes common/gbuffer.glsl with GBUFFER_BINDING defined (receivers and their
// neighbours are read through gbufferPosition / gbufferNormal).
#ifndef PENUMBRA_SHADOW_RECEIVER_GLSL
#define PENUMBRA_SHADOW_RECEIVER_GLSL

#include "common/shadow_map.glsl"

#define SHADOW_RECEIVER_BIAS_NONE 0
#define SHADOW_RECEIVER_BIAS_NORMAL_OFFSET 1
#define SHADOW_RECEIVER_BIAS_PLANE 2

#ifndef SHADOW_RECEIVER_BIAS
#error common/shadow_receiver.glsl: define SHADOW_RECEIVER_BIAS (0 none, 1 normal offset, 2 receiver plane) first
#endif

// A receiver as the map sees it.
struct ShadowReceiver {
    uint face;
    vec2 uv;      // in the face, [0, 1]^2
    float depth;  // reversed-Z NDC
    float w;      // clip w: the distance along the face's axis (perspective), 1 (orthographic)
#if SHADOW_RECEIVER_BIAS == SHADOW_RECEIVER_BIAS_PLANE
    vec2 dDepthDUv;  // the receiver's plane: depth(uv') = depth + dot(dDepthDUv, uv' - uv)
    float epsilon;   // what remains after the plane: rounding (see shadowReceiverPlane)
#endif
};

// The receiver's depth at face uv `uv` with its margin: its own, or its plane's there.
// What the mean depth of the receiver's own surface over a region centred at `uv` is
// (vssm's sub-kernels).
float shadowPlaneDepth(ShadowReceiver r, vec2 uv)
{
#if SHADOW_RECEIVER_BIAS == SHADOW_RECEIVER_BIAS_PLANE
    return r.depth + dot(r.dDepthDUv, uv - r.uv) + r.epsilon;
#else
    return r.depth;
#endif
}

// The depth a caster's texel at face uv `uv` is compared with: the receiver's plane
// there with its margin, never farther from the light than the receiver itself. A caster
// farther than the receiver cannot stand between it and any point of the light (every
// segment from the receiver to the light comes nearer along the face's axis, wherever
// the receiver is farther than the light's own extent along it), but a plane seen
// almost edge-on runs far away within a few texels: the ground beside the foot of a box
// side lit at 80-88 degrees from its normal lay in front of the side's plane there, and
// the filters drew dark specks along the foot (tests/techniques/test_straddled_faces.cpp).
float shadowReferenceDepth(ShadowReceiver r, vec2 uv)
{
#if SHADOW_RECEIVER_BIAS == SHADOW_RECEIVER_BIAS_PLANE
    return max(shadowPlaneDepth(r, uv), r.depth + r.epsilon);  // reversed-Z: larger is nearer
#else
    return r.depth;
#endif
}

// The face uv of a lookup `offsetTexels` from the receiver, kept inside the face and
// moved to the centre of its texel: where the rasterizer evaluated the caster's depth,
// so that a receiver plane is evaluated at the same point.
vec2 shadowTapUv(ShadowReceiver r, vec2 offsetTexels)
{
    return shadowTexelCentre(shadowClampToFace(r.uv + offsetTexels / shadowFaceTexels(), 0.5));
}

// One nearest-texel compare, `offsetTexels` from the receiver: 1 lit, 0 shadowed.
// `map` samples the depth map with compareOp GREATER_OR_EQUAL (reversed-Z: a receiver is
// lit where its depth is at least the stored caster depth).
float shadowCompareTap(sampler2DShadow map, ShadowReceiver r, vec2 offsetTexels)
{
    vec2 centre = shadowTapUv(r, offsetTexels);
    return texture(map, vec3(shadowAtlasUv(r.face, centre), shadowReferenceDepth(r, centre)));
}

// Left-over error once a receiver-side bias has done its work (fp32 positions, the
// rasterizer's depth interpolation, texel-centre rounding), in texels so that it scales
// with the map; the receiver plane's margin is this part of a texel along the light and
// along the plane's slope. Measured on the default scene's box sides, lit at 87 degrees
// from their normal by its light as a spot (hard, receiver plane, 2048 texels, 480 x
// 270): 1/16 of a texel left acne on 0.70% of the pixels, 1/8 on 0.44%, 1/4 on 0.17%,
// 1/2 on 0.06% (those at the boxes' edges). Half a texel is what a slope-scaled bias of
// 0.5 would shift shadows by: contact shadows stay (tests/techniques/test_pcss_plugin.cpp,
// BlockerTouchingTheReceiverCastsAHardShadow).
const float kShadowRoundingTexels = 1.0 / 2.0;
// Beyond 88 degrees between a receiver and the map's iso-depth surface the bias a
// receiver would need grows without bound; shading weights such receivers by N.L ~ 0.
const float kShadowMaxTan = 28.6;  // tan(88 degrees)

#if SHADOW_RECEIVER_BIAS == SHADOW_RECEIVER_BIAS_NORMAL_OFFSET
// The direction in which the map's depth grows fastest at p (towards the light): the
// normal of its iso-depth surface. Orthographic: the light's direction; perspective
// (depth = near / w): the face's backward axis, not the ray to the light.
vec3 shadowDepthGradientDirection(uint face, vec3 p)
{
    mat4 m = shadowMapData.faces[face].viewProj;
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
// times the worst error, for any angle: k >= 0.7 (times the filter's width, which the
// technique applies) is free of self-shadowing. Orthographic maps (alpha = 0) give
// Holbert's sin(theta); a perspective map also needs an offset where a surface faces
// the light off the map's axis. The price: the lookup point moves sideways, so shadows
// shift by up to d on steep receivers.
vec3 shadowOffsetAlongNormal(uint face, vec3 p, vec3 n, float texelWorld, float normalOffsetTexels)
{
    vec3 l = shadowTowardsLight(p);
    float cosTheta = min(abs(dot(n, l)), 1.0);
    float cosAlpha = min(abs(dot(l, shadowDepthGradientDirection(face, p))), 1.0);
    float sinTheta = sqrt(1.0 - cosTheta * cosTheta);
    float tanAlpha = sqrt(1.0 - cosAlpha * cosAlpha) / max(cosAlpha, 1.0 / kShadowMaxTan);
    float factor = min(sinTheta + tanAlpha * cosTheta, kShadowMaxTan);
    return p + n * (texelWorld * (normalOffsetTexels * factor + kShadowRoundingTexels));
}
#endif

#if SHADOW_RECEIVER_BIAS == SHADOW_RECEIVER_BIAS_PLANE || defined(SHADOW_SURFACE_NEIGHBOURS)
// Neighbouring pixels on the receiver's own surface: they give the receiver plane, and
// (define SHADOW_SURFACE_NEIGHBOURS for this part alone) a pixel's
// footprint in the map, for filters that choose a level of detail.
//
// Neighbours give the plane of the triangle the map holds, where the receiver is flat
// at the scale of a pixel: each must lie within 0.6 degrees of the receiver's tangent
// plane (the G-buffer normal), the plane through the three must agree with the normal
// within 3 degrees (a neighbour just across an edge can pass the first test), and they
// must be within 4 texels in the map. On a curved receiver they would give a secant
// plane, which a convex surface rises above between the points (self-shadowing): there
// the tangent plane of the G-buffer normal is used instead, which a convex surface
// stays below.
const float kShadowCoplanarSine = 0.01;
const float kShadowPlaneAgreesCosine = 0.9986;
const float kShadowMaxNeighbourTexels = 4.0;

// Of the two neighbours along `axis`, the one that lies on the receiver's surface; at a
// silhouette neither may.
bool shadowSurfaceNeighbour(ivec2 pixel, ivec2 axis, vec3 p, vec3 n, out vec3 q)
{
    q = p;
    float best = kShadowCoplanarSine;
    bool found = false;
    ivec2 size = gbufferSize();
    for (int side = -1; side <= 1; side += 2) {
        ivec2 at = pixel + side * axis;
        if (any(lessThan(at, ivec2(0))) || any(greaterThanEqual(at, size))) continue;
        vec4 other = gbufferPosition(at);
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
#endif

#if SHADOW_RECEIVER_BIAS == SHADOW_RECEIVER_BIAS_PLANE
// Receiver plane depth bias (Isidoro, "Shadow Mapping: GPU-based Tips and Techniques",
// GDC 2006): the receiver's depth is an affine function of light uv over its plane
// (exact for planes, perspective or orthographic: NDC depth is affine in NDC xy over a
// plane), so each tap compares the texel's caster depth with the plane's depth at that
// texel's centre instead of the receiver's own depth. Self-shadowing of planar
// receivers disappears for any filter radius without pushing shadows away from their
// casters.

// dDepth/dUv of the plane through the receiver and two more points of it, given as
// (uv, depth) differences a and b: solves [a.xy; b.xy] g = [a.z; b.z]. False when the
// two differences are too short to resolve (below 1/64 texel: fp32 noise), longer than
// `maxTexels`, or nearly parallel in uv (the plane is seen edge-on from the light).
bool shadowSolveGradient(vec3 a, vec3 b, float maxTexels, out vec2 g)
{
    g = vec2(0.0);
    float la = length(a.xy), lb = length(b.xy);
    float det = a.x * b.y - a.y * b.x;
    float texels = shadowFaceTexels();
    if (!(min(la, lb) * texels > 1.0 / 64.0) || !(max(la, lb) * texels <= maxTexels) ||
        !(abs(det) > 1e-3 * la * lb))
        return false;
    g = vec2(a.z * b.y - a.y * b.z, a.x * b.z - a.z * b.x) / det;
    return !any(isinf(g)) && !any(isnan(g));
}

bool shadowPlaneAgreesWithNormal(vec3 p, vec3 q1, vec3 q2, vec3 n)
{
    vec3 c = cross(q1 - p, q2 - p);
    float len = length(c);
    return len > 0.0 && abs(dot(c, n)) > kShadowPlaneAgreesCosine * len;
}

bool shadowGradientThrough(uint face, vec3 uvDepth, vec3 q1, vec3 q2, float maxTexels, out vec2 g)
{
    g = vec2(0.0);
    vec3 a, b;
    float wa, wb;
    return shadowProject(face, q1, a, wa) && shadowProject(face, q2, b, wb) &&
           shadowSolveGradient(a - uvDepth, b - uvDepth, maxTexels, g);
}

void shadowReceiverPlane(ivec2 pixel, vec3 p, vec3 n, float texelWorld, inout ShadowReceiver r)
{
    vec3 uvDepth = vec3(r.uv, r.depth);
    // zStep: the depth gained by moving one texel (its world size here) towards the light.
    float zStep = 0.0;
    vec3 stepped;
    float w;
    if (shadowProject(r.face, p + shadowTowardsLight(p) * texelWorld, stepped, w))
        zStep = max(stepped.z - r.depth, 0.0);

    // The plane through the receiver and its neighbours on the same flat surface;
    // failing that, the tangent plane of the G-buffer normal through two points a texel
    // away.
    vec2 g = vec2(0.0);
    vec3 q1, q2;
    bool fromNeighbours = shadowSurfaceNeighbour(pixel, ivec2(1, 0), p, n, q1) &&
                          shadowSurfaceNeighbour(pixel, ivec2(0, 1), p, n, q2) &&
                          shadowPlaneAgreesWithNormal(p, q1, q2, n) &&
                          shadowGradientThrough(r.face, uvDepth, q1, q2, kShadowMaxNeighbourTexels, g);
    if (!fromNeighbours && dot(n, n) > 0.0) {
        vec3 t1 = normalize(cross(n, abs(n.y) < 0.9 ? vec3(0.0, 1.0, 0.0) : vec3(1.0, 0.0, 0.0)));
        vec3 t2 = cross(n, t1);
        shadowGradientThrough(r.face, uvDepth, p + t1 * texelWorld, p + t2 * texelWorld, kShadowMaxTan, g);
    }
    // |g| per texel is at most (tan(theta) + tan(alpha)) · zStep (theta: the plane's
    // normal to the ray, alpha: the ray to the map's iso-depth normal; see
    // shadowOffsetAlongNormal): clamped where that passes tan(88 degrees).
    float perTexel = length(g) / shadowFaceTexels();
    float maxPerTexel = kShadowMaxTan * zStep;
    if (perTexel > maxPerTexel) {
        g *= maxPerTexel / perTexel;  // perTexel > maxPerTexel >= 0: no division by zero
        perTexel = maxPerTexel;
    }
    r.dDepthDUv = g;
    // The rounding margin: along the light, and along the plane's slope.
    r.epsilon = kShadowRoundingTexels * (zStep + perTexel);
}
#endif

// The receiver seen in `pixel` at world position `p`. False where the map has nothing to
// say (behind the light, outside the map): V = 1 there by contract, the light's own cone
// gives zero light in shading. `normalOffsetTexels` is read with bias 1 only.
// Branch-free up to the receiver plane (common/shadow_map.glsl: uniform loads), so
// callers call it for every pixel and select on the result.
bool makeShadowReceiver(ivec2 pixel, vec3 p, float normalOffsetTexels, out ShadowReceiver r)
{
#if SHADOW_RECEIVER_BIAS != SHADOW_RECEIVER_BIAS_NONE
    vec3 n = gbufferNormal(pixel);
#endif
    // The G-buffer's position is rebuilt from the camera depth: the true surface point
    // lies within gbufferPositionError of it, on any side. Taken at its nearest to the
    // light, so that the surface never shadows itself for that reason (an error of a few
    // 1e-7 of the camera distance: far below any shadow detail, but the size of the
    // ulp-scaled rasterizer biases).
    p += shadowTowardsLight(p) * gbufferPositionError(p);
    vec3 uvDepth;
    float w;
#if SHADOW_RECEIVER_BIAS == SHADOW_RECEIVER_BIAS_NORMAL_OFFSET
    uint ownFace = shadowFaceOf(p);
    bool ownProjected = shadowProject(ownFace, p, uvDepth, w);
    vec3 offset = shadowOffsetAlongNormal(ownFace, p, n, w * shadowMapData.faces[ownFace].texel.x, normalOffsetTexels);
    p = ownProjected ? offset : p;
#endif
    r.face = shadowFaceOf(p);
    bool projected = shadowProject(r.face, p, uvDepth, w);
    bool inMap = all(bvec3(projected, all(greaterThanEqual(uvDepth.xy, vec2(0.0))), all(lessThanEqual(uvDepth.xy, vec2(1.0)))));
    r.face = inMap ? r.face : 0u;
    r.uv = inMap ? uvDepth.xy : vec2(0.0);
    r.depth = inMap ? uvDepth.z : 0.0;
    r.w = inMap ? w : 0.0;
#if SHADOW_RECEIVER_BIAS == SHADOW_RECEIVER_BIAS_PLANE
    r.dDepthDUv = vec2(0.0);
    r.epsilon = 0.0;
    float texelWorld = w * shadowMapData.faces[r.face].texel.x;
    if (inMap) shadowReceiverPlane(pixel, p, n, texelWorld, r);
#endif
    return inMap;
}

#endif
