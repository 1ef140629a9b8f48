// The G-buffer, written by the engine's G-buffer pass (engine/gbuffer.frag) and read by
// shading and the techniques. It holds what no pass can rebuild more cheaply:
//   gbuffer.depth   D32_SFLOAT, reversed-Z (infinite far plane), 0 where nothing was drawn
//   gbuffer.normal  RG16_SNORM, the unit world normal facing the camera, octahedral
//   gbuffer.albedo  RGBA8, linear base colour (read by shading alone)
// World positions are rebuilt from the depth with the camera's inverse view-projection.
//
// Read it only through gbufferPosition / gbufferNormal below, so that the layout can
// change without touching a technique: define GBUFFER_BINDING (the first of three
// consecutive bindings) before including this file, and have the C++ side declare and
// bind them with plugin::readGBuffer / plugin::bindGBuffer (penumbra/plugin/GBuffer.h;
// plugin::addVisibilityPass does both).
//
// Precision of a rebuilt position p: the fp32 depth (near / distance, rounded and
// interpolated by the rasterizer) places p along its pixel's ray to a few 1e-7 of its
// distance from the eye, and adding the eye rounds to half an ulp of |p|. Its distance
// to the surface is at most gbufferPositionError(p) = 5e-7 · (|p - eye| + |p|); measured
// at most 0.4 of that (2e-7) over every pixel of the default scene at scene scales 1e-3,
// 1 and 1e5 and with the near plane at 1e-5 (the view 3.5e6 near distances deep)
// (tests/engine/frame/test_gbuffer_precision.cpp). Along the surface p may slide by
// more at grazing angles (the rasterizer snaps vertices to a subpixel grid), which moves
// no shadow. The RGBA32F position stored before was exact to 6e-8 of |p|; the receivers
// of common/shadow_receiver.glsl allow for the difference (gbufferPositionError).
#ifndef PENUMBRA_GBUFFER_GLSL
#define PENUMBRA_GBUFFER_GLSL

// Octahedral normal encoding (Cigolle et al., "A Survey of Efficient Representations for
// Independent Unit Vectors", JCGT 2014): 2 x 16 bits, steps of 1/32767 on the
// octahedron, so the decoded direction is within about 5e-5 rad of the written one
// (the survey's figure for oct32), far below any shading or bias detail. SNORM, not
// UNORM: 0 and ±1 are exact, so axis-aligned normals (floors, walls) decode exactly
// (UNORM's 0.5 is not a step: a floor's normal would tilt by 1.5e-5 rad, enough to move
// an area light's sample across a receiver's horizon).
vec2 gbufferSignNotZero(vec2 v)
{
    return vec2(v.x >= 0.0 ? 1.0 : -1.0, v.y >= 0.0 ? 1.0 : -1.0);
}

// A unit vector -> [-1, 1]^2 (an RG16_SNORM target stores it).
vec2 gbufferEncodeNormal(vec3 n)
{
    vec3 a = abs(n);
    float l1 = a.x + a.y + a.z;
    vec2 p = l1 > 0.0 ? n.xy / l1 : vec2(0.0);
    if (n.z < 0.0) p = (1.0 - abs(p.yx)) * gbufferSignNotZero(p);
    return p;
}

vec3 gbufferDecodeNormal(vec2 p)
{
    vec3 n = vec3(p, 1.0 - abs(p.x) - abs(p.y));
    float t = max(-n.z, 0.0);
    n.xy -= t * gbufferSignNotZero(n.xy);
    return normalize(n);  // |n| >= 1/sqrt(3): never zero
}

#ifdef GBUFFER_BINDING
layout(binding = GBUFFER_BINDING) uniform sampler2D gDepth;
layout(binding = GBUFFER_BINDING + 1) uniform sampler2D gNormal;
layout(std140, binding = GBUFFER_BINDING + 2) uniform GBufferCamera {
    // The camera's perspective (infinite far plane, reversed-Z: depth = near / distance
    // along the view axis) as an eye and a ray per pixel: the point at NDC (x, y, depth)
    // is eye + (x rayX + y rayY + rayZ) / depth; the rays reach the near plane. Set up in
    // double precision on the CPU (FrameRenderer::setCamera). The eye is added last and
    // exactly as configured: an fp32 inverse view-projection would rebuild it from
    // eye / near and 1 / near, each rounded, and shift every position by a few 1e-7 of
    // |eye| the same way (enough for a plane to shadow itself under an ulp-sized bias).
    vec4 eye;
    vec4 rayX;
    vec4 rayY;
    vec4 rayZ;
    vec4 size;  // xy: the G-buffer's size in pixels
} gCamera;

ivec2 gbufferSize()
{
    return ivec2(gCamera.size.xy);
}

// The world position of the surface seen at the centre of `pixel`, w = 1; (0, 0, 0, 0)
// where the pixel sees no geometry.
// Branch-free, as every helper a full-screen pass calls (docs/performance.md, "Uniform
// loads"): the camera's fields are loaded once per SIMD group only outside divergent
// control flow on llvmpipe.
vec4 gbufferPosition(ivec2 pixel)
{
    float depth = texelFetch(gDepth, pixel, 0).r;
    bool seen = depth > 0.0;
    vec2 ndc = (vec2(pixel) + 0.5) / gCamera.size.xy * 2.0 - 1.0;
    vec3 ray = ndc.x * gCamera.rayX.xyz + ndc.y * gCamera.rayY.xyz + gCamera.rayZ.xyz;
    vec3 p = gCamera.eye.xyz + ray / (seen ? depth : 1.0);
    return seen ? vec4(p, 1.0) : vec4(0.0);
}

// A bound on the distance from gbufferPosition(pixel) = p to the surface point it stands
// for: the depth's fp32 rounding and the rasterizer's interpolation (a few ulps of the
// distance from the eye), and the rounding of the eye's addition (half an ulp of |p|).
// Measured (tests/engine/frame/test_gbuffer_precision.cpp) at most 0.4 of it.
const float kGBufferRelativeError = 5e-7;
float gbufferPositionError(vec3 p)
{
    return kGBufferRelativeError * (length(p - gCamera.eye.xyz) + length(p));
}

// The unit world normal at `pixel`, facing the camera. Meaningful where
// gbufferPosition(pixel).w is 1 (elsewhere a direction the clear value encodes).
vec3 gbufferNormal(ivec2 pixel)
{
    return gbufferDecodeNormal(texelFetch(gNormal, pixel, 0).rg);
}
#endif

#endif
