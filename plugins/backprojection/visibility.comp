#version 460
// Soft shadows by back-projection of the occluders' contour (Guennebaud, Barthe, Paulin
// 2007, "[GBP07]" in Yang, Feng, Guennebaud, Liu 2009), for one light, per G-buffer
// pixel (README.md next to this file; contour.glsl does the work):
//   1. the kernel: the region of the map where an occluder can hide part of the light
//      from the receiver (eq. 1, as the light's corners project through the receiver),
//      first down to the map's near plane, then refined twice down to the nearest
//      occluder the multi-scale shadow map (mssm.glsl) finds in the last kernel;
//      nothing nearer than the receiver in it: lit; all of it nearer: umbra (step 5);
//   2. the contour: every 2 x 2 block of samples in the kernel classified against the
//      receiver (occluder: nearer the light than the receiver's plane there), marching
//      squares on the dual grid gives the edges between occluders and the rest;
//      TRAVERSAL 0 visits every block, 1 descends the MSSM from the node that covers the
//      kernel at its corner and prunes nodes whose samples are all occluders or all not
//      (Yang et al. 2009 §4.2, Algorithm 3) - the same edges, fewer fetches;
//   3. the integration: each edge back-projected from the receiver onto the light's
//      plane, clipped to the light, and its hidden area integrated radially around the
//      light's centre (light_area.glsl). V = 1 - occluded area / light area.
// With PACKET > 1 the packet pass (packets.comp) ran first and left each pixel's V, or
// -1 where the pixel walks its own kernel here (Algorithm 1's step 8).
// With LAYERS 2 (the multi-layer alternative of §5: Bavoil et al. 2008, Schwarz and
// Stamminger 2007) a depth-peeled second layer holds, per texel, the nearest surface
// behind the first: each layer gets its own kernel (eq. 8) and contour, and V counts
// the light that either hides once (contour.glsl backprojectionVisibility).
// Light size 0 takes the hard shadow's one nearest compare.
// With VIEWS > 1 (Yang et al. 2009 §5) the light is split into VIEWS sub-lights, each
// with its own map, MSSM and pass: each adds V / VIEWS of its sub-light to the sum of the
// passes before it (viewsIn; cleared for the first), so that the last one writes the average. The
// sums are stored as V is (R16_UNORM: within 7.7e-6), so the average is within
// VIEWS x 7.7e-6 of the exact sum's.
#ifndef DEBUG_IMAGES
#define DEBUG_IMAGES 0
#endif
#ifndef PACKET
#define PACKET 1
#endif
#ifndef VIEWS
#define VIEWS 1
#endif

layout(local_size_x = 8, local_size_y = 8) in;

#include "contour.glsl"

#if !DEBUG_IMAGES
layout(binding = 2, VISIBILITY_FORMAT) uniform writeonly image2D visibilityOut;
#define OUTPUT_SIZE imageSize(visibilityOut)
#if VIEWS > 1
layout(binding = 14, VISIBILITY_FORMAT) uniform readonly image2D viewsIn;
#endif
#endif

#if PACKET > 1
// packets.comp's result per pixel: (V or -1, class, samples and nodes read, kernel side).
layout(binding = 12, rgba32f) uniform readonly image2D packetsIn;
#endif

// With DEBUG_IMAGES (the debug_views pass, which the graph runs only when one of its
// images is requested: backprojection.cpp) the same work writes, instead of V, each
// pixel's kernel side in texels (kernelOut), the depth-map samples and MSSM nodes it
// read (visitedOut; the paper's Fig. 5 and 8; a coherent packet's walk shared among the
// pixels that walked it) and how its V was found (coherenceOut: contour.glsl's classes),
// 0 without geometry.
#if DEBUG_IMAGES
layout(binding = 10, r32f) uniform writeonly image2D kernelOut;
layout(binding = 11, r32f) uniform writeonly image2D visitedOut;
layout(binding = 13, r32f) uniform writeonly image2D coherenceOut;
#define OUTPUT_SIZE imageSize(kernelOut)
#endif

void main()
{
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = OUTPUT_SIZE;
    bool inImage = all(lessThan(pixel, size));
    pixel = min(pixel, size - 1);

    vec4 position = gbufferPosition(pixel);
    ShadowReceiver r;
    bool inMap = makeShadowReceiver(pixel, position.xyz, 0.0, r);
    float kernelTexels = 0.0;
    int fetches = 0;
    float soft = 1.0;
    LightPlane light = lightPlaneFor(position.xyz);
    bool hasSize = light.area > 0.0 && shadowMapData.faces[r.face].texel.x > 0.0;
    bool soften = inMap && position.w != 0.0 && hasSize;
    int coherence = soften ? kClassPerPixel : kClassNone;
#if PACKET > 1
    vec4 packet = imageLoad(packetsIn, pixel);
    bool done = packet.x >= 0.0;
    coherence = soften ? int(packet.y) : coherence;
    soft = done ? packet.x : soft;
    fetches = done ? int(packet.z) : fetches;
    kernelTexels = done ? packet.w : kernelTexels;
#else
    const bool done = false;
#endif
    if (soften && !done) {
        bool walked;
        soft = backprojectionVisibility(r, position.xyz, light, kernelTexels, fetches, walked);
#if PACKET == 1
        coherence = walked ? kClassPerPixel : kClassDecided;
#endif
    }
    // A light of size 0 casts a hard shadow: exactly hard's one nearest compare.
    float hard = shadowCompareTap(shadowCompare, r, vec2(0.0));
    float v = hasSize ? soft : hard;
    v = shadowVisibilityAboveHorizon(inMap ? v : 1.0, position.xyz, gbufferNormal(pixel));
    v = position.w != 0.0 ? v : VISIBILITY_NO_GEOMETRY;
#if DEBUG_IMAGES
    bool seen = position.w != 0.0;
    if (inImage) imageStore(kernelOut, pixel, vec4(seen ? kernelTexels : 0.0));
    if (inImage) imageStore(visitedOut, pixel, vec4(seen ? float(fetches) : 0.0));
    if (inImage) imageStore(coherenceOut, pixel, vec4(float(coherence)));
#else
    v = sanitizeVisibility(v);
#if VIEWS > 1
    v = sanitizeVisibility(imageLoad(viewsIn, pixel).x + v * (1.0 / float(VIEWS)));
#endif
    if (inImage) imageStore(visibilityOut, pixel, vec4(v));
#endif
}
