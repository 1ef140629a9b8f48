#version 460
// The adaptive shadow map's analysis (thesis ch. 2, "Creating nodes", "Sampling"), on the
// GPU: one G-buffer pixel in `stride` (a pattern that moves every frame, so that a still
// view sees every pixel in `stride` frames) is projected into the light view and
// walked to the finest resident node over it. Per node it counts
//   used     the pixels whose lookup ends there (they keep it and its ancestors alive),
//   edges    those of them on a shadow edge at the node's resolution: the 3 x 3 compares
//            around the lookup disagree (a shadow boundary passes within a texel),
//   benefit  per quadrant, the edge pixels whose shadow-map texel is larger than the
//            pixel itself (texel side * texelsPerPixel > the pixel's footprint side, both
//            in light-view uv): a child there would resolve them.
// The pixel's footprint is the area its neighbours' positions span in light-view uv (the
// projected area the thesis gets from mip-mapping), taken on the side of each axis whose
// neighbour lies nearer in uv (not across a geometric edge).
#define GBUFFER_BINDING 4
#include "common/gbuffer.glsl"

#ifndef ASM_TILE
#define ASM_TILE 128
#define ASM_ATLAS_COLUMNS 16
#define ASM_MAX_LEVEL 10
#define ASM_PAGE_LEVEL 6
#endif

layout(local_size_x = 64, local_size_y = 1) in;

layout(binding = 1) uniform sampler2D atlas;

#define SHADOW_MAP_BINDING 3
#define SHADOW_RECEIVER_BIAS 0
#include "common/shadow_receiver.glsl"

#define ASM_NODES_BINDING 8
#define ASM_PAGES_BINDING 11
#include "asm_tree.glsl"

// tile_tree.h NodeAnalysis: used, edges, benefit[4] per node.
layout(std430, binding = 10) buffer AsmAnalysis {
    uint counts[];
} analysis;

layout(push_constant) uniform Push {
    uint frame;
    uint stride;
    float texelsPerPixel;
} pc;

// The uv of the neighbour `pixel + axis` or `pixel - axis`, whichever lies nearer to `uv`
// in the light view; false when neither has geometry in front of the light.
bool neighbourStep(ivec2 pixel, ivec2 axis, uint face, vec2 uv, out vec2 stepUv)
{
    stepUv = vec2(0.0);
    float best = 1e30;
    bool found = false;
    ivec2 size = gbufferSize();
    for (int s = -1; s <= 1; s += 2) {
        ivec2 q = pixel + s * axis;
        if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) continue;
        vec4 p = gbufferPosition(q);
        vec3 uvDepth;
        float w;
        if (p.w == 0.0 || !shadowProject(face, p.xyz, uvDepth, w)) continue;
        vec2 d = uvDepth.xy - uv;
        if (dot(d, d) < best) {
            best = dot(d, d);
            stepUv = d;
            found = true;
        }
    }
    return found;
}

void main()
{
    // Invocation (i, y) analyzes pixel (i stride + phase, y), the phase chosen so that
    // (x + 3 y) % stride == frame % stride: only the sampled pixels run (a lane that
    // returned at once would still cost its SIMD group the whole path on llvmpipe).
    ivec2 size = gbufferSize();
    uint y = gl_GlobalInvocationID.y;
    uint phase = (pc.frame % pc.stride + pc.stride * 3u - (3u * y) % pc.stride) % pc.stride;
    ivec2 pixel = ivec2(gl_GlobalInvocationID.x * pc.stride + phase, y);
    if (any(greaterThanEqual(pixel, size))) return;
    vec4 position = gbufferPosition(pixel);
    if (position.w == 0.0) return;
    // A surface facing away from the light is dark whatever the map says.
    if (dot(gbufferNormal(pixel), shadowTowardsLight(position.xyz)) <= 0.0) return;
    ShadowReceiver r;
    if (!makeShadowReceiver(pixel, position.xyz, 0.0, r)) return;

    int node = asmFinestNode(r.face, r.uv);
    vec2 local = asmCellUv(node, r.uv);
    uint base = uint(node) * 6u;
    atomicAdd(analysis.counts[base], 1u);

    int lit = 0;
    for (int y = -1; y <= 1; ++y)
        for (int x = -1; x <= 1; ++x) {
            vec2 tap = clamp(local + vec2(x, y) / float(ASM_TILE), vec2(0.0), vec2(1.0));
            lit += r.depth >= texelFetch(atlas, asmAtlasTexel(node, tap), 0).r ? 1 : 0;
        }
    if (lit == 0 || lit == 9) return;
    atomicAdd(analysis.counts[base + 1u], 1u);

    if (asmTree.nodes[node].level >= uint(ASM_MAX_LEVEL)) return;
    vec2 du, dv;
    if (!neighbourStep(pixel, ivec2(1, 0), r.face, r.uv, du) || !neighbourStep(pixel, ivec2(0, 1), r.face, r.uv, dv))
        return;
    float pixelSide = sqrt(abs(du.x * dv.y - du.y * dv.x));
    if (asmTexelUv(node) * pc.texelsPerPixel <= pixelSide) return;
    uint quadrant = uint(local.x >= 0.5) + 2u * uint(local.y >= 0.5);
    atomicAdd(analysis.counts[base + 2u + quadrant], 1u);
}
