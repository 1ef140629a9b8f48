#version 460
// visibility::OcclusionTraversal, receiver-mask mode: an occlusion query (a box, or a leaf's
// casters) counts only the samples on a texel of the dilated receiver mask, in which each
// mask texel stands for a block of maskBlock x maskBlock view texels (the paper's
// Listing 1.2). The query rasterises at the view's resolution.
//
// Views whose technique compares with the receivers' own depth are not queried: they are
// culled on the CPU against the receiver depths (visibility/ReceiverFloorCulling.h).
layout(binding = 1) uniform sampler2D receiverMask;

layout(push_constant) uniform Push {
    mat4 viewProj;
    int maskBlock;
} pc;

void main()
{
    if (texelFetch(receiverMask, ivec2(gl_FragCoord.xy) / pc.maskBlock, 0).r < 0.5) discard;
}
