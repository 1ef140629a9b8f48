#version 460
// visibility::OcclusionTraversal, receiver-mask mode: an occlusion query (a box, or a leaf's casters)
// counts only the samples that can change what a visible receiver gets from the map (the
// paper's Listing 1.2). The query rasterises at the view's resolution.
//
// That is, first, every sample on a texel of the dilated receiver mask, in which each
// mask texel stands for a block of maskBlock x maskBlock view texels.
//
// With a receiver-depth image (the technique compares every lookup with the receiver's own depth,
// CasterView::compareTapRadius), receiverDepth holds per view texel the farthest depth
// that any visible receiver point whose lookups read the texel compares with
// (engine/receiver_scatter.comp, engine/receiver_depth_min.comp; all ones: none). A
// sample counts only when the technique would store it in front of that depth: after the
// technique's rasterizer bias it shadows some receiver, and otherwise it cannot, whatever
// else is drawn. Lit receivers that shadow nothing the camera sees are not drawn.
layout(binding = 1) uniform sampler2D receiverMask;
layout(binding = 2, r32ui) uniform readonly uimage2D receiverDepth;

layout(location = 0) in vec3 world;

layout(push_constant) uniform Push {
    mat4 viewProj;
    int maskBlock;
    int ownDepth;     // 1: test receiverDepth too
    float biasSlope;  // the technique's slope-scaled bias; 0 for box proxies
    float biasClamp;  // its clamp in NDC depth; 0: none
} pc;

// The depth of rounding between this reprojection and the technique's rasterizer
// (interpolation of world positions and of z / w): a few fp32 ulps of depths <= 1.
const float kDepthRounding = 4.0 / 16777216.0;

void main()
{
    // The mask first, in every case: it covers every texel a receiver depth was spread
    // to, and it is one fetch where the test below is a projection and a load.
    if (texelFetch(receiverMask, ivec2(gl_FragCoord.xy) / pc.maskBlock, 0).r < 0.5) discard;
    if (pc.ownDepth == 0) return;
    // The depth the technique's rasterizer gives this sample, from the world position:
    // gl_FragCoord.z may or may not include the culling pass's own depth bias.
    vec4 clip = pc.viewProj * vec4(world, 1.0);
    float depth = clip.z / clip.w;  // clip.w > 0 inside the view
    // The technique stores it moved away from the light by its bias: at least the slope
    // term (Vulkan's slope m is at least the larger screen derivative; the constant term
    // is left out, which only keeps more), at most its clamp. Box proxies take none: the
    // geometry inside lies behind their front faces.
    float slope = max(abs(dFdx(depth)), abs(dFdy(depth)));
    float bias = 0.99 * pc.biasSlope * slope;
    if (pc.biasClamp > 0.0) bias = min(bias, pc.biasClamp);
    float stored = depth - bias + kDepthRounding;
    if (isnan(stored)) return;  // keep what cannot be judged
    // Non-negative floats order as their bits (receiver depths are stored clamped to 0;
    // below 0 lies beyond the far plane). Equal is kept, though the technique calls it lit.
    uint farthest = imageLoad(receiverDepth, ivec2(gl_FragCoord.xy)).r;
    if (floatBitsToUint(max(stored, 0.0)) < farthest) discard;
}
