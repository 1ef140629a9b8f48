#version 460
// render::Visibility, step 2: the reverse shadow test (the paper's Listing 1.1). A
// receiver fragment seen from the light enters the mask when the camera sees it: it
// projects inside the screen, in front of the near plane, and no farther than the camera
// depth there. The depth it is compared with is the farthest of the 3 x 3 camera pixels
// around it, and it may lie a relative `depthTolerance` behind that: the light's texel
// centre and the camera's pixel centre sample the surface at different points, and a
// texel dropped from the mask would cull a caster that a visible pixel needs. Erring
// wide costs only culling. The mask is written with image stores, so that a receiver
// fragment hidden from the light behind another receiver still marks its texel (the
// shadow map's texel there must hold the nearer receiver and everything in front of it).
layout(location = 0) in vec3 inWorld;

layout(binding = 1) uniform sampler2D cameraDepth;  // reversed-Z: near / view depth
layout(binding = 2, r8) uniform writeonly image2D receiverMask;
layout(push_constant) uniform Push {
    mat4 lightViewProj;
    int maskBlock;  // view texels per mask texel, per side
} pc;
layout(std430, binding = 3) readonly buffer Camera {
    mat4 viewProj;
    vec4 params;  // xy: camera image size, z: relative depth tolerance
} camera;

void main()
{
    vec4 clip = camera.viewProj * vec4(inWorld, 1.0);
    if (clip.w <= 0.0) return;
    vec3 ndc = clip.xyz / clip.w;
    if (any(greaterThan(abs(ndc.xy), vec2(1.0))) || ndc.z > 1.0 || ndc.z < 0.0) return;
    ivec2 size = ivec2(camera.params.xy);
    ivec2 pixel = clamp(ivec2((ndc.xy * 0.5 + 0.5) * vec2(size)), ivec2(0), size - 1);
    float farthest = 1.0;
    for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx)
            farthest = min(farthest, texelFetch(cameraDepth, clamp(pixel + ivec2(dx, dy), ivec2(0), size - 1), 0).r);
    // Reversed-Z depth is near / d: "d_fragment <= d_camera * (1 + tolerance)".
    if (ndc.z * (1.0 + camera.params.z) >= farthest) imageStore(receiverMask, ivec2(gl_FragCoord.xy) / pc.maskBlock, vec4(1.0));
}
