#version 460
// Occlusion-query proxies of visibility::OcclusionTraversal: the bounding boxes of BVH nodes,
// boxes[gl_InstanceIndex] (one instanced draw per query: a multi-query draws several),
// 12 triangles each from gl_VertexIndex. Both faces are drawn (no culling), so a box
// seen from inside still produces fragments; boxes that reach in front of the near plane
// are never queried (the traversal treats them as visible).
struct Box {
    vec4 lo;
    vec4 hi;
};
layout(std430, binding = 0) readonly buffer Boxes { Box boxes[]; };

layout(push_constant) uniform Push {
    mat4 viewProj;
} pc;

// The 36 corners of the 12 triangles, as bit masks: bit 0 x, bit 1 y, bit 2 z (1 = hi).
const uint kCorners[36] = uint[36](0, 2, 1, 1, 2, 3,   // z lo
                                   4, 5, 6, 5, 7, 6,   // z hi
                                   0, 1, 4, 1, 5, 4,   // y lo
                                   2, 6, 3, 3, 6, 7,   // y hi
                                   0, 4, 2, 2, 4, 6,   // x lo
                                   1, 3, 5, 3, 7, 5);  // x hi

void main()
{
    Box box = boxes[gl_InstanceIndex];
    uint c = kCorners[gl_VertexIndex % 36];
    vec3 p = vec3((c & 1u) != 0u ? box.hi.x : box.lo.x, (c & 2u) != 0u ? box.hi.y : box.lo.y,
                  (c & 4u) != 0u ? box.hi.z : box.lo.z);
    gl_Position = pc.viewProj * vec4(p, 1.0);
}
