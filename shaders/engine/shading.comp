#version 460
// The shading pass (engine/shading.glsl) where every light's V_l is an image or 1: the
// frame composes the same head, then the visibility functions that shading evaluates,
// before the body (frame/FrameRenderer.cpp).
#define GBUFFER_BINDING 0
#include "common/gbuffer.glsl"
#include "common/visibility.glsl"
#include "engine/shading.glsl"
