#version 460
// visibility::ReceiverMaskBuilder, step 2, for views with receiver depths: the receiver
// floor, per mask texel the least (farthest from the light) receiver depth over the block
// of view texels it stands for, after the spreading over the technique's taps
// (engine/receiver_depth_min.comp). Read back with the mask, it lets the CPU cull, without
// a query (visibility/ReceiverFloorCulling.h), every node whose box lies behind that depth
// at every mask texel it covers: it can shadow no receiver there. Only texels of the
// dilated mask are read; elsewhere the floor is none.
layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 0, r8) uniform readonly image2D mask;             // dilated, mask texels
layout(std430, binding = 1) readonly buffer ReceiverDepth { uint receiverDepth[]; };  // view texels, row by row
layout(binding = 2, r32ui) uniform writeonly uimage2D receiverFloor;  // mask texels

layout(push_constant) uniform Push {
    int maskSize;    // mask texels per side
    int maskBlock;   // view texels per mask texel, per side
    int resolution;  // view texels per side
} pc;

const uint kNone = 0xffffffffu;  // no receiver (as in receiverDepth)

void main()
{
    // The push constants are loaded before the first branch: on llvmpipe a uniform value
    // is loaded once per SIMD group only outside divergent control flow
    // (docs/performance.md, "Uniform loads").
    int maskSize = pc.maskSize, maskBlock = pc.maskBlock, resolution = pc.resolution;
    ivec2 cell = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(cell, ivec2(maskSize)))) return;
    uint floorBits = kNone;
    if (imageLoad(mask, cell).r >= 0.5) {
        ivec2 lo = cell * maskBlock;
        ivec2 hi = min(lo + maskBlock, ivec2(resolution));
        for (int y = lo.y; y < hi.y; ++y)
            for (int x = lo.x; x < hi.x; ++x) floorBits = min(floorBits, receiverDepth[y * resolution + x]);
    }
    imageStore(receiverFloor, cell, uvec4(floorBits));
}
