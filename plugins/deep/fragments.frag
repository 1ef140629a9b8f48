#version 460
// The deep shadow map's fragment pass (§1.3.1, Listing 1.2): every caster fragment the
// light sees, with no depth test, is appended to its texel's list: a node taken from the
// pool by an atomic counter, linked in front of the list's head by an atomic exchange.
// The vertex shader is render::ShadowMap's (engine/shadow_depth.vert with ALPHA_MASK: the
// texture coordinate and the material).
//
// A fragment's alpha: 1 for opaque materials, 1 for alpha-masked ones above their cutoff
// (below it a hole: no fragment), the material's times its texture's alpha for
// translucent (BLEND) ones. A fragment of alpha 0 (or NaN) changes no transmittance and
// takes no node.
//
// Early fragment tests against the opaque casters' depth (render::ShadowMap's
// addOpaqueDepthPass, no depth write): a fragment behind the nearest surface that lets no
// light through could only multiply a transmittance of 0, and never runs this shader;
// that surface's own fragment passes (equal depth) and ends the list. So a texel of an
// opaque scene holds one node, and hair behind a head none.
//
// The pool holds `capacity` nodes. A fragment past it is counted (counters.fragments goes
// on rising) and not stored: the lists stay well formed, the technique sees by how much
// the pool fell short (deep.cpp) and grows it.
#include "common/scene.glsl"

#define DEEP_NODES_BINDING 4
#define DEEP_NODES_WRITE
#include "deep_lists.glsl"
#include "deep_counters.glsl"

layout(early_fragment_tests) in;

layout(location = 0) in vec2 inUv;
layout(location = 1) flat in uint inMaterial;

layout(std430, binding = 1) readonly buffer Materials { MaterialData materials[]; };
layout(binding = 2) uniform sampler2D baseColorTexture;
layout(binding = 3, r32ui) uniform coherent uimage2D heads;

layout(push_constant) uniform Push {
    layout(offset = 64) uint capacity;  // after the vertex shader's lightViewProj
    float depthBias;  // in r: the resolution of a 32-bit float depth at the fragment
    float slopeBias;  // times the fragment's depth slope
} pc;

// The rasterizer's depth bias for a floating-point depth format (Vulkan, "Depth Bias"),
// away from the light (reversed-Z: smaller): m slopeBias + r depthBias, with m the
// fragment's largest depth slope in x or y (exact: depth is linear across a triangle in
// the viewport) and r = 2^(e - 23) for the exponent e of its depth (the spec takes the
// triangle's largest; the fragment's own differs only where a triangle spans a power of
// two). Applied here, not by the rasterizer, so that the early depth test compares the
// fragment's own depth with the opaque casters' and the stored depth carries the bias on
// any device (whether FragCoord.z includes the rasterizer's bias is not specified).
float biasedDepth(float z)
{
    int e;
    frexp(max(z, 1e-30), e);  // z = m 2^e, m in [0.5, 1): the IEEE exponent is e - 1
    float r = exp2(float(e - 24));
    float slope = max(abs(dFdx(z)), abs(dFdy(z)));
    return max(z - (slope * pc.slopeBias + r * pc.depthBias), 0.0);
}

void main()
{
    float depth = biasedDepth(gl_FragCoord.z);  // before any discard: derivatives need the whole quad
    MaterialData material = materials[inMaterial];
    float a = material.baseColor.a * texture(baseColorTexture, inUv).a;
    if (material.alphaMode == ALPHA_MODE_MASK && a < material.alphaCutoff) discard;
    float alpha = material.alphaMode == ALPHA_MODE_BLEND ? clamp(a, 0.0, 1.0) : 1.0;
    if (!(alpha > 0.0)) discard;
    uint node = atomicAdd(counters.fragments, 1u);
    if (node >= pc.capacity) return;
    nodes[node].depth = depth;
    nodes[node].transmittance = alpha;
    nodes[node].next = imageAtomicExchange(heads, ivec2(gl_FragCoord.xy), node);
}
