#version 460
// Pipeline::dispatchOver's test: every invocation inside a width x height grid counts
// itself at its cell, every one outside counts itself once in `overhang`. The local size
// is neither 8 nor square, so a dispatch that assumed 8 x 8 would miss or repeat cells.
layout(local_size_x = 16, local_size_y = 4) in;

layout(std430, binding = 0) buffer Hits { uint hits[]; };
layout(std430, binding = 1) buffer Overhang { uint overhang; };

layout(push_constant) uniform Push {
    uvec2 size;
} pc;

void main()
{
    uvec2 cell = gl_GlobalInvocationID.xy;
    if (any(greaterThanEqual(cell, pc.size))) {
        atomicAdd(overhang, 1u);
        return;
    }
    atomicAdd(hits[cell.y * pc.size.x + cell.x], 1u);
}
