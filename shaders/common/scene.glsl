// Per-instance and per-material data shared by every pass that draws scene geometry.
// Rows are ordered for batched draws (render/DrawBatches.h): a draw's firstInstance is
// the row of its first instance, so gl_InstanceIndex finds each instance's row.
#ifndef PENUMBRA_SCENE_GLSL
#define PENUMBRA_SCENE_GLSL

struct InstanceData {
    mat4 model;
    mat4 normalMatrix;  // inverse-transpose of model (w column unused)
    uvec4 info;         // x: material index
};

#define ALPHA_MODE_OPAQUE 0u
#define ALPHA_MODE_MASK 1u
#define ALPHA_MODE_BLEND 2u

struct MaterialData {
    vec4 baseColor;     // linear rgb, a = alpha (times the texture's)
    float alphaCutoff;  // ALPHA_MODE_MASK: alpha below it is a hole
    uint alphaMode;
    uint pad0;
    uint pad1;
};

// A material's alpha test as a vertex shader hands it on: x the cutoff, y 1 for
// ALPHA_MODE_MASK. Vertex shaders read the material and pass its constants as flat
// varyings: a fragment shader on llvmpipe loads a storage buffer once per lane (the
// G-buffer pass 1.2-1.4x faster, docs/performance.md, "Uniform loads").
vec2 materialAlphaTest(MaterialData material)
{
    return vec2(material.alphaCutoff, material.alphaMode == ALPHA_MODE_MASK ? 1.0 : 0.0);
}

// Whether a fragment of `baseColor` (the material's times its texture's) is a hole.
bool materialCutsHole(vec4 baseColor, vec2 alphaTest)
{
    return alphaTest.y != 0.0 && baseColor.a < alphaTest.x;
}

#endif
