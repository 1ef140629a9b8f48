#version 460
// render::Visibility, receiver-mask mode: an occlusion query (a box, or a leaf's casters)
// counts only the samples on texels of the dilated receiver mask (the paper's Listing
// 1.2). The mask has the view's resolution and the query the view's viewport, so the
// fragment's own texel is the one to test.
layout(binding = 1) uniform sampler2D receiverMask;

void main()
{
    if (texelFetch(receiverMask, ivec2(gl_FragCoord.xy), 0).r < 0.5) discard;
}
