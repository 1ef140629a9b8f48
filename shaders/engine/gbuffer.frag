#version 460
#include "common/gbuffer.glsl"

layout(location = 0) in vec3 inPositionWorld;
layout(location = 1) in vec3 inNormalWorld;
layout(location = 2) flat in vec4 inBaseColor;

layout(location = 0) out vec4 outPosition;
layout(location = 1) out vec4 outNormal;
layout(location = 2) out vec4 outAlbedo;

void main()
{
    vec3 n = normalize(inNormalWorld);
    // Two-sided lighting: a back face seen by the camera is lit from its visible side.
    if (!gl_FrontFacing) n = -n;
    outPosition = vec4(inPositionWorld, 1.0);
    outNormal = vec4(n, 0.0);
    outAlbedo = inBaseColor;
}
