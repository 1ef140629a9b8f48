// G-buffer layout, written by the engine's G-buffer pass and read by techniques and
// shading. Positions are world space in full fp32 (techniques reproject them into light
// space; a reconstructed position would add error at large scene scales).
#ifndef PENUMBRA_GBUFFER_GLSL
#define PENUMBRA_GBUFFER_GLSL

#define GBUFFER_POSITION_FORMAT rgba32f  // xyz world position, w = 1 where geometry, 0 background
#define GBUFFER_NORMAL_FORMAT rgba16f    // xyz world normal (unit), w unused
#define GBUFFER_ALBEDO_FORMAT rgba8      // rgb base colour (linear), a = alpha

#endif
