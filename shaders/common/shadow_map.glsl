// A light's shadow map as render::ShadowMap (render/ShadowMap.h) describes it: one face
// (spot: perspective, directional: orthographic) or six cube faces (point, rect and
// disk lights: 90° each plus the technique's guard band beyond every edge, which
// receivers never pick, they land in the 90° part) packed 3 x 2 in one atlas, each with
// its world -> clip matrix. Every map
// is reversed-Z: NDC depth 1 at the near plane, towards 0 away from the light, 0 where
// nothing was drawn.
//
// The including shader defines SHADOW_MAP_BINDING, the binding of the storage buffer
// ShadowMap::buffer() (ShadowMapData), before including this file; with SHADOW_MAP_ARRAY
// also defined, the buffer is an array of ShadowMapData (below).
//
// A technique's map has one layout for the technique's lifetime; compiled in (the
// defines of render::ShadowMap::shaderDefines(): SHADOW_FACE_COUNT, SHADOW_FACE_TEXELS,
// SHADOW_LIGHT_TYPE), the branches on it fold away and no lookup loads it (llvmpipe
// runs both sides of every branch on a value it cannot see is uniform: the light-type
// branches of shadowLightAboveHorizon cost a spot light's hard shadows 7 of 24 ms).
// Without them (an array of maps, a shader tool) they are read from the buffer.
//
// Every function here is branch-free or loads the buffer before it branches: a
// full-screen pass loads a uniform value once per SIMD group on llvmpipe only outside
// divergent control flow, and once per lane inside it (docs/performance.md, "Uniform
// loads").
#ifndef PENUMBRA_SHADOW_MAP_GLSL
#define PENUMBRA_SHADOW_MAP_GLSL

#ifndef SHADOW_MAP_BINDING
#error common/shadow_map.glsl: define SHADOW_MAP_BINDING (the binding of render::ShadowMap::buffer()) first
#endif

struct ShadowFace {
    mat4 viewProj;    // world -> clip, reversed-Z
    vec4 texel;       // x: world size of one texel per unit of clip w
    vec4 depthRange;  // x near, y far: distances along the face's axis; z: 1 orthographic
};

// render::ShadowMapData (std430, 640 bytes: its sizeof).
struct ShadowMapInfo {
    vec4 light;       // xyz position (w = 1) or unit direction towards the light (w = 0)
    uint faceCount;   // 1, or 6 cube faces in a 3 x 2 atlas
    float faceTexels; // texels per face side
    uint lightType;   // scene::LightType: 0 directional, 1 spot, 2 point, 3 rect, 4 disk
    uint pad0;
    vec4 lightAxis;     // xyz unit emitting normal (rect, disk); w: rect half width, disk or
                        // sphere radius, sine of a directional light's angular radius
    vec4 lightTangent;  // rect: xyz unit width axis, w half height
    ShadowFace faces[6];
};

#ifdef SHADOW_MAP_ARRAY
// Several maps of one light's shape (the reference's rasterised light samples): the
// buffer holds one render::ShadowMapData per map, and every function below reads the
// map that `shadowMapIndex` names: set it before calling them.
layout(std430, binding = SHADOW_MAP_BINDING) readonly buffer ShadowMapArrayBuffer {
    ShadowMapInfo maps[];
} shadowMapArray;
uint shadowMapIndex = 0u;
#define shadowMapData shadowMapArray.maps[shadowMapIndex]
#else
layout(std430, binding = SHADOW_MAP_BINDING) readonly buffer ShadowMapBuffer {
    ShadowMapInfo map;
} shadowMapBuffer;
#define shadowMapData shadowMapBuffer.map
#endif

#if defined(SHADOW_MAP_ARRAY) && (defined(SHADOW_FACE_COUNT) || defined(SHADOW_FACE_TEXELS) || defined(SHADOW_LIGHT_TYPE))
#error common/shadow_map.glsl: SHADOW_FACE_COUNT, SHADOW_FACE_TEXELS and SHADOW_LIGHT_TYPE describe one map, not an array
#endif
#ifdef SHADOW_LIGHT_TYPE
#define shadowLightType() uint(SHADOW_LIGHT_TYPE)
#else
#define shadowLightType() shadowMapData.lightType
#endif
#ifdef SHADOW_FACE_TEXELS
#define shadowFaceTexels() float(SHADOW_FACE_TEXELS)
#else
#define shadowFaceTexels() shadowMapData.faceTexels
#endif
#ifdef SHADOW_FACE_COUNT
#define shadowFaceCount() uint(SHADOW_FACE_COUNT)
#else
#define shadowFaceCount() shadowMapData.faceCount
#endif

// The area fraction of a unit disk on the far side of a line at signed distance h from
// its centre (h = 1: the whole disk, 0: half, -1: none).
float shadowCircularSegment(float h)
{
    h = clamp(h, -1.0, 1.0);
    return (acos(-h) + h * sqrt(max(1.0 - h * h, 0.0))) / 3.14159265358979;
}

// P(b u + c v > -a) for u, v uniform in [-1, 1]: the area fraction of a square above a
// line (the sum of two uniforms has a trapezoidal CDF).
float shadowSquareAboveLine(float a, float b, float c)
{
    float p = max(abs(b), abs(c)), q = min(abs(b), abs(c));
    if (!(p > 1e-6 * abs(a))) return a > 0.0 ? 1.0 : 0.0;  // the line misses the square's scale
    if (q < 1e-3 * p) return clamp((a + p) / (2.0 * p), 0.0, 1.0);  // one axis: a uniform's CDF
    // F(x) = [R(x+p+q) - R(x+p-q) - R(x-p+q) + R(x-p-q)] / (8 p q), R(t) = max(t, 0)^2.
    float x = -a;
    vec4 t = max(vec4(x + p + q, x + p - q, x - p + q, x - p - q), vec4(0.0));
    t *= t;
    float below = (t.x - t.y - t.z + t.w) / (8.0 * p * q);  // p >= q >= 1e-3 p > 0
    return clamp(1.0 - below, 0.0, 1.0);
}

// The part of the light above the tangent plane of a receiver at p with unit normal n
// (the G-buffer's, facing the camera): light from below it is blocked by the surface
// itself, so V counts only this part (shaders/common/visibility.glsl). In the reference's
// measure: exact for rect and disk lights (area), for sphere and directional lights
// (solid angle) the cap is taken as a flat disk of the same angular radius, exact to
// first order in that radius. n = 0 (no normal): 1.
float shadowLightAboveHorizon(vec3 p, vec3 n)
{
    vec4 light = shadowMapData.light;
    vec4 axis = shadowMapData.lightAxis;
    vec4 tangent = shadowMapData.lightTangent;
    uint type = shadowLightType();
    // a: the light's centre above the plane; the light's points lie at a + (their offset
    // from the centre) . n.
    float a = dot(n, light.xyz - p);
    float above = a > 0.0 ? 1.0 : 0.0;  // spot, point without radius
    if (type == 0u) {  // directional: light.xyz is the unit direction towards it
        float sinElevation = dot(n, light.xyz);
        above = axis.w > 0.0 ? shadowCircularSegment(sinElevation / axis.w) : (sinElevation > 0.0 ? 1.0 : 0.0);
    } else if (type == 3u) {
        above = shadowSquareAboveLine(a, axis.w * dot(n, tangent.xyz), tangent.w * dot(n, cross(axis.xyz, tangent.xyz)));
    } else if (type == 4u) {
        // The disk's points: the centre plus up to radius along the plane's normal
        // projected into the disk's plane, |m| of it.
        vec3 m = n - axis.xyz * dot(n, axis.xyz);
        float reach = axis.w * length(m);
        above = reach > 1e-6 * abs(a) ? shadowCircularSegment(a / reach) : above;
    } else if (type == 2u && axis.w > 0.0) {
        above = shadowCircularSegment(a / axis.w);  // a sphere: sin(elev) / sin(radius)
    }
    return dot(n, n) > 0.0 ? above : 1.0;
}

// A technique's V from what its map says (`mapVisibility`, seen from the light's centre)
// and the horizon: what every shadow-map technique writes.
//
// Where an area light straddles a receiver's tangent plane with its centre below it (a
// box side lit by a rect light that reaches past the side's plane), the segment from the
// centre to the receiver lies wholly below the plane, and so does every caster the map
// can hold nearer than the receiver's plane: the receiver's own solid. Such casters
// cannot block the part of the light above the plane, which is all the horizon leaves,
// and the map from below the plane holds nothing about the casters above it. So there
// the horizon alone is V (exact for a convex solid; a caster above the plane that hides
// that part is missed). Taking the map's word instead drew such sides dark, V ~ 0.1
// where the truth is 0.4, as the centre's point light would.
//
// With the centre just above the plane the map sees the receiver almost edge-on, past
// what a receiver-side bias can hold (kShadowGrazingCos: 88 degrees from the normal,
// shadow_receiver.glsl's kShadowMaxTan), and its own surface shadows it in speckles and
// bands; while the light straddles the plane, the part above it is lit from well above
// the plane, so such a receiver is not negligible in shading. There the map's word fades
// out between 85 and 88 degrees, and out as the light comes to straddle the plane (over
// the last 5 % of it above): a light wholly above the plane (a point light, a low sun)
// keeps the map's word at every angle.
const float kShadowTrustedCos = 0.08716;  // cos(85 degrees)
const float kShadowGrazingCos = 0.03490;  // cos(88 degrees)
float shadowVisibilityAboveHorizon(float mapVisibility, vec3 p, vec3 n)
{
    vec4 light = shadowMapData.light;
    float horizon = shadowLightAboveHorizon(p, n);
    // light.w = 0: light.xyz is the unit direction towards a directional light.
    vec3 towards = light.w == 0.0 ? light.xyz : light.xyz - p;
    float len = length(towards);
    float cosCentre = len > 0.0 ? dot(n, towards) / (len > 0.0 ? len : 1.0) : 1.0;
    float straddles = clamp((1.0 - horizon) / 0.05, 0.0, 1.0);
    float grazing = 1.0 - smoothstep(kShadowGrazingCos, kShadowTrustedCos, cosCentre);
    float untrusted = cosCentre > 0.0 ? grazing * straddles : 1.0;
    untrusted = dot(n, n) > 0.0 ? untrusted : 0.0;
    return mix(mapVisibility, 1.0, untrusted) * horizon;
}

// Face order +X -X +Y -Y +Z -Z, as render/Projection.cpp builds them.
uint shadowCubeFace(vec3 d)
{
    vec3 a = abs(d);
    uint face = d.z > 0.0 ? 4u : 5u;
    face = a.y >= a.z ? (d.y > 0.0 ? 2u : 3u) : face;
    return all(greaterThanEqual(a.xx, a.yz)) ? (d.x > 0.0 ? 0u : 1u) : face;
}

uint shadowFaceOf(vec3 world)
{
    return shadowFaceCount() == 6u ? shadowCubeFace(world - shadowMapData.light.xyz) : 0u;
}

// Face uv, NDC depth and clip w of a world point. False behind the light (w <= 0: the
// division would mirror the point or blow up) and for anything not finite.
bool shadowProject(uint face, vec3 world, out vec3 uvDepth, out float w)
{
    vec4 clip = shadowMapData.faces[face].viewProj * vec4(world, 1.0);
    w = clip.w;
    bool inFront = clip.w > 0.0;
    float divisor = inFront ? clip.w : 1.0;
    vec3 q = vec3(clip.xy / divisor * 0.5 + 0.5, clip.z / divisor);
    uvDepth = inFront ? q : vec3(0.0);
    return inFront && !any(isinf(q)) && !any(isnan(q));
}

// Unit vector from `p` towards the light; zero when p is at the light.
vec3 shadowTowardsLight(vec3 p)
{
    vec4 light = shadowMapData.light;
    vec3 d = light.xyz - p;
    float len = length(d);
    vec3 towards = len > 0.0 ? d / (len > 0.0 ? len : 1.0) : vec3(0.0);
    return shadowLightType() == 0u ? light.xyz : towards;  // directional: light.w = 0
}

// Face uv -> uv in the whole map (the atlas cell of `face`).
vec2 shadowAtlasUv(uint face, vec2 faceUv)
{
    vec2 grid = shadowFaceCount() == 6u ? vec2(3.0, 2.0) : vec2(1.0);
    return (vec2(face % 3u, face / 3u) + faceUv) / grid;
}

// The face whose atlas cell holds atlas texel `texel` (a one-face map has one cell).
uint shadowFaceOfTexel(ivec2 texel)
{
    uvec2 cell = uvec2(max(texel, ivec2(0))) / uint(shadowFaceTexels());
    return min(cell.y * 3u + cell.x, shadowFaceCount() - 1u);
}

// Keeps a lookup `marginTexels` inside its face: the next cell of the atlas is another
// cube face, not the continuation of this one. A cube face reaches past its 90° by the
// technique's guard band (render::ShadowMap guardTexels), where lookups beyond the cube
// edge read the casters there; only lookups beyond the band read its border texels. For
// a one-face map this is the clamp to the map's edge.
// `faceTexels`: texels per face side of the image read (a filtered map's level may have
// fewer than the depth map).
vec2 shadowClampToFace(vec2 uv, float marginTexels, float faceTexels)
{
    float margin = marginTexels / faceTexels;
    return clamp(uv, vec2(margin), vec2(1.0 - margin));
}

vec2 shadowClampToFace(vec2 uv, float marginTexels)
{
    return shadowClampToFace(uv, marginTexels, shadowFaceTexels());
}

// The centre of the texel `uv` falls in: where the rasterizer evaluated the casters'
// depth.
vec2 shadowTexelCentre(vec2 uv)
{
    return (floor(uv * shadowFaceTexels()) + 0.5) / shadowFaceTexels();
}

// Distance from the light along the face's axis (world units) of a map depth, within
// the face's [near, far]. Perspective: depth = near / d; 0 (nothing drawn) and anything
// below near / far read as far, so no division by zero. Orthographic: depth falls
// linearly from 1 at near to 0 at far.
// shadowDistanceInRange takes the face's depthRange, loaded once outside a loop.
float shadowDistanceInRange(vec4 range, float ndcDepth)
{
    float orthographic = mix(range.y, range.x, clamp(ndcDepth, 0.0, 1.0));
    return range.z != 0.0 ? orthographic : range.x / max(ndcDepth, range.x / range.y);
}

float shadowDistance(uint face, float ndcDepth)
{
    return shadowDistanceInRange(shadowMapData.faces[face].depthRange, ndcDepth);
}

// The same distance normalised to [0, 1] over the face's [near, far]: the depth that
// filtered maps store, independent of the scene's scale. ShadowMap keeps far > near.
float shadowLinearDepthInRange(vec4 range, float ndcDepth)
{
    return clamp((shadowDistanceInRange(range, ndcDepth) - range.x) / (range.y - range.x), 0.0, 1.0);
}

float shadowLinearDepth(uint face, float ndcDepth)
{
    return shadowLinearDepthInRange(shadowMapData.faces[face].depthRange, ndcDepth);
}

#endif
