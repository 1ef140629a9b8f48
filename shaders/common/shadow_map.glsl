// A light's shadow map as render::ShadowMap (render/ShadowMap.h) describes it: one face
// (spot: perspective, directional: orthographic) or six 90° cube faces (point, rect and
// disk lights) packed 3 x 2 in one atlas, each with its world -> clip matrix. Every map
// is reversed-Z: NDC depth 1 at the near plane, towards 0 away from the light, 0 where
// nothing was drawn.
//
// The including shader defines SHADOW_MAP_BINDING, the binding of the storage buffer
// ShadowMap::buffer() (ShadowMapData), before including this file; with SHADOW_MAP_ARRAY
// also defined, the buffer is an array of ShadowMapData (below).
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

#ifdef SHADOW_MAP_ARRAY
// Several maps of one light's shape (the reference's rasterised light samples): the
// buffer holds one render::ShadowMapData per map (std430 array stride 608, as its
// sizeof), and every function below reads the map that `shadowMapIndex` names: set it
// before calling them.
struct ShadowMapInfo {
    vec4 light;
    uint faceCount;
    float faceTexels;
    uint pad0;
    uint pad1;
    ShadowFace faces[6];
};
layout(std430, binding = SHADOW_MAP_BINDING) readonly buffer ShadowMapArrayBuffer {
    ShadowMapInfo maps[];
} shadowMapArray;
uint shadowMapIndex = 0u;
#define shadowMapData shadowMapArray.maps[shadowMapIndex]
#else
layout(std430, binding = SHADOW_MAP_BINDING) readonly buffer ShadowMapBuffer {
    vec4 light;       // xyz position (w = 1) or unit direction towards the light (w = 0)
    uint faceCount;   // 1, or 6 cube faces in a 3 x 2 atlas
    float faceTexels; // texels per face side
    uint pad0;
    uint pad1;
    ShadowFace faces[6];
} shadowMapData;
#endif

// Face order +X -X +Y -Y +Z -Z, as render/Projection.cpp builds them.
uint shadowCubeFace(vec3 d)
{
    vec3 a = abs(d);
    if (a.x >= a.y && a.x >= a.z) return d.x > 0.0 ? 0u : 1u;
    if (a.y >= a.z) return d.y > 0.0 ? 2u : 3u;
    return d.z > 0.0 ? 4u : 5u;
}

uint shadowFaceOf(vec3 world)
{
    return shadowMapData.faceCount == 6u ? shadowCubeFace(world - shadowMapData.light.xyz) : 0u;
}

// Face uv, NDC depth and clip w of a world point. False behind the light (w <= 0: the
// division would mirror the point or blow up) and for anything not finite.
bool shadowProject(uint face, vec3 world, out vec3 uvDepth, out float w)
{
    vec4 clip = shadowMapData.faces[face].viewProj * vec4(world, 1.0);
    w = clip.w;
    uvDepth = vec3(0.0);
    if (!(clip.w > 0.0)) return false;
    uvDepth = vec3(clip.xy / clip.w * 0.5 + 0.5, clip.z / clip.w);
    return !any(isinf(uvDepth)) && !any(isnan(uvDepth));
}

// Unit vector from `p` towards the light; zero when p is at the light.
vec3 shadowTowardsLight(vec3 p)
{
    if (shadowMapData.light.w == 0.0) return shadowMapData.light.xyz;
    vec3 d = shadowMapData.light.xyz - p;
    float len = length(d);
    return len > 0.0 ? d / len : vec3(0.0);
}

// Face uv -> uv in the whole map (the atlas cell of `face`).
vec2 shadowAtlasUv(uint face, vec2 faceUv)
{
    vec2 grid = shadowMapData.faceCount == 6u ? vec2(3.0, 2.0) : vec2(1.0);
    return (vec2(face % 3u, face / 3u) + faceUv) / grid;
}

// Keeps a lookup `marginTexels` inside its face: the next cell of the atlas is another
// cube face, not the continuation of this one. Lookups beyond a cube edge read the
// face's border texels instead of the adjacent face (an error confined to a filter
// radius around cube edges); for a one-face map this is the clamp to the map's edge.
// `faceTexels`: texels per face side of the image read (a filtered map's level may have
// fewer than the depth map).
vec2 shadowClampToFace(vec2 uv, float marginTexels, float faceTexels)
{
    float margin = marginTexels / faceTexels;
    return clamp(uv, vec2(margin), vec2(1.0 - margin));
}

vec2 shadowClampToFace(vec2 uv, float marginTexels)
{
    return shadowClampToFace(uv, marginTexels, shadowMapData.faceTexels);
}

// The centre of the texel `uv` falls in: where the rasterizer evaluated the casters'
// depth.
vec2 shadowTexelCentre(vec2 uv)
{
    return (floor(uv * shadowMapData.faceTexels) + 0.5) / shadowMapData.faceTexels;
}

// Distance from the light along the face's axis (world units) of a map depth, within
// the face's [near, far]. Perspective: depth = near / d; 0 (nothing drawn) and anything
// below near / far read as far, so no division by zero. Orthographic: depth falls
// linearly from 1 at near to 0 at far.
float shadowDistance(uint face, float ndcDepth)
{
    vec4 range = shadowMapData.faces[face].depthRange;
    if (range.z != 0.0) return mix(range.y, range.x, clamp(ndcDepth, 0.0, 1.0));
    return range.x / max(ndcDepth, range.x / range.y);
}

// The same distance normalised to [0, 1] over the face's [near, far]: the depth that
// filtered maps store, independent of the scene's scale. ShadowMap keeps far > near.
float shadowLinearDepth(uint face, float ndcDepth)
{
    vec4 range = shadowMapData.faces[face].depthRange;
    return clamp((shadowDistance(face, ndcDepth) - range.x) / (range.y - range.x), 0.0, 1.0);
}

#endif
