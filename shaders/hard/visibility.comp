#version 460
// Hard shadow: one depth comparison per pixel (nearest texel), written as V_l.
// The shadow map is reversed-Z, so a receiver is lit when its light-space depth is
// greater than or equal to the stored (biased, hence smaller) caster depth; the sampler
// does the comparison (compareOp GREATER_OR_EQUAL). Spot and directional lights have one
// frustum; point, rect and disk lights six cube faces packed 3 x 2 in one atlas, the
// face chosen by the dominant axis of the direction from the light.
#include "common/gbuffer.glsl"
#include "common/visibility.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 0, GBUFFER_POSITION_FORMAT) uniform readonly image2D gPosition;
layout(binding = 1) uniform sampler2DShadow shadowMap;
layout(binding = 2, VISIBILITY_FORMAT) uniform writeonly image2D visibilityOut;
layout(std430, binding = 3) readonly buffer Frusta { mat4 faceViewProj[]; };

layout(push_constant) uniform Push {
    vec4 lightPosition;  // xyz, for choosing a cube face
    uint faceCount;      // 1 or 6
    float faceTexels;    // shadow-map texels per face side
} pc;

// Face order +X -X +Y -Y +Z -Z, as render/Projection.cpp builds them.
uint cubeFace(vec3 d)
{
    vec3 a = abs(d);
    if (a.x >= a.y && a.x >= a.z) return d.x > 0.0 ? 0u : 1u;
    if (a.y >= a.z) return d.y > 0.0 ? 2u : 3u;
    return d.z > 0.0 ? 4u : 5u;
}

void main()
{
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(pixel, imageSize(visibilityOut)))) return;

    vec4 position = imageLoad(gPosition, pixel);
    float v = VISIBILITY_NO_GEOMETRY;
    if (position.w != 0.0) {
        uint face = pc.faceCount == 6u ? cubeFace(position.xyz - pc.lightPosition.xyz) : 0u;
        vec4 clip = faceViewProj[face] * vec4(position.xyz, 1.0);
        // Behind the light (w <= 0) or outside the map: the light's cone (shading) gives
        // zero light there, so the shadow map has nothing to say: V = 1.
        if (clip.w > 0.0) {
            vec3 ndc = clip.xyz / clip.w;
            vec2 uv = ndc.xy * 0.5 + 0.5;
            if (all(greaterThanEqual(uv, vec2(0.0))) && all(lessThanEqual(uv, vec2(1.0)))) {
                if (pc.faceCount == 6u) {
                    // Stay half a texel inside the face: its neighbour in the atlas is
                    // another face, not the continuation of this one.
                    float margin = 0.5 / pc.faceTexels;
                    uv = (vec2(face % 3u, face / 3u) + clamp(uv, vec2(margin), vec2(1.0 - margin))) / vec2(3.0, 2.0);
                }
                v = texture(shadowMap, vec3(uv, ndc.z));
            }
        }
    }
    imageStore(visibilityOut, pixel, vec4(sanitizeVisibility(v)));
}
