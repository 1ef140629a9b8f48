// The PCSS framework's kernel sizes (Fernando 2005, "Percentage-Closer Soft Shadows"),
// shared by the techniques built on it (plugins/pcss, plugins/vssm): the blocker search
// region and the penumbra width, in texels of a render::ShadowMap face.
//
// `lightSize`: for lights at a position, w_light in world units (the penumbra is
// (d_r - d_b) w_light / d_b wide); for a directional light, the penumbra width per unit
// of receiver-blocker distance, 2 tan(angular diameter / 2) (plugin-side
// render::softShadowLightSize).
//
// Include after common/shadow_map.glsl.
#ifndef PENUMBRA_PENUMBRA_ESTIMATE_GLSL
#define PENUMBRA_PENUMBRA_ESTIMATE_GLSL

bool shadowDirectionalLight() { return shadowLightType() == 0u; }

// A radius in texels, clamped to [0, maxTexels]; NaN (from 0 * inf) becomes 0, +inf the
// maximum.
float shadowClampRadius(float texels, float maxTexels) { return texels >= 0.0 ? min(texels, maxTexels) : 0.0; }

// Where to look for blockers: the light seen from the receiver at distance d_r, cut by
// the plane where the nearest blockers can be. Fernando's searchWidth = w_light (d_r -
// near) / d_r on the near plane; divided by near it is an angle (tan units), which is
// what a perspective texel measures (texel.x: world per unit of distance). Orthographic:
// every ray is parallel, so the light's angular size spreads over (d_r - near) of depth,
// in world units like the texel. Returns the half-width.
float shadowSearchRadiusTexels(ShadowFace face, float lightSize, float dReceiver, float maxTexels)
{
    float near = face.depthRange.x;
    float extent = shadowDirectionalLight() ? (dReceiver - near) * lightSize
                                            : (lightSize / near) * ((dReceiver - near) / dReceiver);
    return shadowClampRadius(0.5 * extent / face.texel.x, maxTexels);
}

// The penumbra's half-width in texels at the receiver: w = (d_r - d_b) w_light / d_b,
// as an angle from the light w / d_r (perspective), or (d_r - d_b) 2 tan(θ/2) in world
// units (directional). d_r - d_b is clamped at 0 (a blocker at the receiver makes the
// shadow hard: contact hardening) and d_b below at the near plane (every caster lies
// beyond it; d_b -> 0 cannot blow the ratio up).
float shadowFilterRadiusTexels(ShadowFace face, float lightSize, float dReceiver, float dBlocker, float maxTexels)
{
    float gap = max(dReceiver - dBlocker, 0.0);
    float width = shadowDirectionalLight() ? gap * lightSize
                                           : (gap / dReceiver) * (lightSize / max(dBlocker, face.depthRange.x));
    return shadowClampRadius(0.5 * width / face.texel.x, maxTexels);
}

#endif
