// The PCSS framework's kernel sizes (Fernando 2005, "Percentage-Closer Soft Shadows"),
// shared by the techniques built on it (plugins/pcss, plugins/vssm): the blocker search
// region and the penumbra width, in texels of a render::ShadowMap face.
//
// `lightSize`: for lights at a position, w_light in world units (the penumbra is
// (d_r - d_b) w_light / d_b wide); for a directional light, the penumbra width per unit
// of receiver-blocker distance, 2 tan(angular diameter / 2) (plugin-side
// render::softShadowLightSize), per axis of the face: shadowLightExtent gives a rect or
// disk light's own extent along each as the receiver sees it, so the kernels are
// rectangles whose half-widths follow a tilted or oblong light.
//
// Include after common/shadow_map.glsl.
#ifndef PENUMBRA_PENUMBRA_ESTIMATE_GLSL
#define PENUMBRA_PENUMBRA_ESTIMATE_GLSL

bool shadowDirectionalLight() { return shadowLightType() == 0u; }

// A radius in texels, clamped to [0, maxTexels]; NaN (from 0 * inf) becomes 0, +inf the
// maximum.
float shadowClampRadius(float texels, float maxTexels) { return texels >= 0.0 ? min(texels, maxTexels) : 0.0; }
vec2 shadowClampRadius(vec2 texels, float maxTexels)
{
    return vec2(shadowClampRadius(texels.x, maxTexels), shadowClampRadius(texels.y, maxTexels));
}

// The light's size along the face's u and v axes as the receiver at world position `p`
// sees it: a rect or disk light's own shape (`ownShape`), else `lightSize` both ways (a
// light without a shape of its own, a directional light's angle, or a technique's
// light_size parameter: a square). To first order in the light's size, the kernels are
// where the rays from p to the light cross the blockers' plane: a point q of the light
// (from its centre c) moves them as its projection along p's ray onto the face's plane
// through c, q.u - (q.a) m_u along u, where a is the face's axis and m = the receiver's
// (d.u, d.v) / d.a, d = p - c. So a light tilted against the face counts its depth
// where the receiver looks at it obliquely, and an oblong light its two sides.
vec2 shadowLightExtent(ShadowFace face, vec3 p, float lightSize, bool ownShape)
{
    uint type = shadowLightType();
    if (!ownShape || (type != 3u && type != 4u) || face.depthRange.z != 0.0) return vec2(lightSize);
    // The face's axes from its world -> clip matrix: clip w is the distance along a
    // (unit: the view is a rotation), and clip x, y mix u, v with a (an off-centre crop).
    mat4 m = face.viewProj;
    vec3 a = vec3(m[0][3], m[1][3], m[2][3]);
    a /= max(length(a), 1e-30);
    vec3 rowU = vec3(m[0][0], m[1][0], m[2][0]), rowV = vec3(m[0][1], m[1][1], m[2][1]);
    vec3 u = rowU - dot(rowU, a) * a, v = rowV - dot(rowV, a) * a;
    u /= max(length(u), 1e-30);
    v /= max(length(v), 1e-30);
    vec3 d = p - shadowMapData.light.xyz;
    float along = max(dot(d, a), 1e-6 * length(d));
    vec3 wu = u - (dot(d, u) / along) * a, wv = v - (dot(d, v) / along) * a;
    vec3 n = shadowMapData.lightAxis.xyz;
    if (type == 3u) {
        vec3 t1 = shadowMapData.lightTangent.xyz, t2 = cross(n, t1);
        vec2 halfSize = vec2(shadowMapData.lightAxis.w, shadowMapData.lightTangent.w);
        return 2.0 * vec2(halfSize.x * abs(dot(t1, wu)) + halfSize.y * abs(dot(t2, wu)),
                          halfSize.x * abs(dot(t1, wv)) + halfSize.y * abs(dot(t2, wv)));
    }
    // A disk of radius r reaches r |w - (w.n) n| along w.
    float r = shadowMapData.lightAxis.w;
    return 2.0 * r * vec2(length(wu - dot(wu, n) * n), length(wv - dot(wv, n) * n));
}

// Where to look for blockers: the light seen from the receiver at distance d_r, cut by
// the plane where the nearest blockers can be. Fernando's searchWidth = w_light (d_r -
// near) / d_r on the near plane; divided by near it is an angle (tan units), which is
// what a perspective texel measures (texel.x: world per unit of distance). Orthographic:
// every ray is parallel, so the light's angular size spreads over (d_r - near) of depth,
// in world units like the texel. Returns the half-width.
vec2 shadowSearchRadiusTexels(ShadowFace face, vec2 lightSize, float dReceiver, float maxTexels)
{
    float near = face.depthRange.x;
    vec2 extent = shadowDirectionalLight() ? (dReceiver - near) * lightSize
                                           : (lightSize / near) * ((dReceiver - near) / dReceiver);
    return shadowClampRadius(0.5 * extent / face.texel.x, maxTexels);
}

// The penumbra's half-width in texels at the receiver: w = (d_r - d_b) w_light / d_b,
// as an angle from the light w / d_r (perspective), or (d_r - d_b) 2 tan(θ/2) in world
// units (directional). d_r - d_b is clamped at 0 (a blocker at the receiver makes the
// shadow hard: contact hardening) and d_b below at the near plane (every caster lies
// beyond it; d_b -> 0 cannot blow the ratio up).
vec2 shadowFilterRadiusTexels(ShadowFace face, vec2 lightSize, float dReceiver, float dBlocker, float maxTexels)
{
    float gap = max(dReceiver - dBlocker, 0.0);
    vec2 width = shadowDirectionalLight() ? gap * lightSize
                                          : (gap / dReceiver) * (lightSize / max(dBlocker, face.depthRange.x));
    return shadowClampRadius(0.5 * width / face.texel.x, maxTexels);
}

#endif
