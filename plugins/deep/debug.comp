#version 460
// The deep shadow map's debug images, one invocation per texel of the atlas (nothing
// reads them: the graph runs this pass only when one is requested, render --debug-image):
//   depth_complexity  fragments that reached the texel (before the sort's cut)
//   list_length       nodes its list keeps after truncation
//   transmittance     the light left at linear depth `debugDepth` along the face (0 at
//                     the face's near plane, 1 at its far plane): what a receiver there
//                     would read without filtering
#define DEEP_NODES_BINDING 3
#include "deep_lists.glsl"
#define SHADOW_MAP_BINDING 4
#include "common/shadow_map.glsl"

layout(local_size_x = 64, local_size_y = 1) in;

layout(binding = 0, r32ui) uniform readonly uimage2D heads;
layout(binding = 1, r32ui) uniform readonly uimage2D lengths;
layout(binding = 2, r32f) uniform writeonly image2D complexityOut;
layout(binding = 5, r32f) uniform writeonly image2D lengthOut;
layout(binding = 6, r32f) uniform writeonly image2D transmittanceOut;

layout(push_constant) uniform Push {
    float debugDepth;
} pc;

// The map depth (reversed-Z NDC) of linear depth t in [0, 1] along a face: the inverse of
// shadowLinearDepthInRange.
float ndcOfLinearDepth(vec4 range, float t)
{
    float distance = mix(range.x, range.y, clamp(t, 0.0, 1.0));
    return range.z != 0.0 ? 1.0 - clamp(t, 0.0, 1.0) : range.x / max(distance, range.x);
}

void main()
{
    ivec2 texel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(texel, imageSize(heads)))) return;
    uint packed = imageLoad(lengths, texel).r;
    uint kept = packed & 0xFFFFu;
    vec4 range = shadowMapData.faces[shadowFaceOfTexel(texel)].depthRange;
    uint head = kept == 0u ? kDeepNone : imageLoad(heads, texel).r;
    float tau = deepTransmittance(deepSeek(head, kDeepNone, ndcOfLinearDepth(range, pc.debugDepth)));
    imageStore(complexityOut, texel, vec4(float(packed >> 16)));
    imageStore(lengthOut, texel, vec4(float(kept)));
    imageStore(transmittanceOut, texel, vec4(tau));
}
