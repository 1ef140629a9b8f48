#version 460
// render::Visibility, receiver-mask mode: an occlusion query (a box, or a leaf's casters)
// counts only the samples on texels of the dilated receiver mask (the paper's Listing
// 1.2). The query rasterises at the view's resolution; each mask texel stands for a block
// of maskBlock x maskBlock view texels.
layout(binding = 1) uniform sampler2D receiverMask;

layout(push_constant) uniform Push {
    mat4 viewProj;
    int maskBlock;
} pc;

void main()
{
    if (texelFetch(receiverMask, ivec2(gl_FragCoord.xy) / pc.maskBlock, 0).r < 0.5) discard;
}
