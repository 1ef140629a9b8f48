#version 460
// render::Visibility, step 2: the receiver mask. The paper rasterises the visible
// receivers from the light and keeps the fragments that pass the reverse shadow test
// against the camera depth; the texels it keeps are those whose surface point a camera
// pixel sees. This pass marks the same texels from the camera's side: every camera pixel
// with geometry is unprojected from the camera depth and marks the texel of the light
// view it falls in. Exact (no depth tolerance), and one invocation per pixel instead of a
// reverse test per receiver fragment at the map's resolution, which on a CPU rasteriser
// cost more than the casters it saved (docs/culling.md).
layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 0) uniform sampler2D cameraDepth;  // reversed-Z, 0 where nothing was drawn
layout(binding = 1, r8) uniform writeonly image2D receiverMask;
layout(std430, binding = 2) readonly buffer Camera {
    mat4 inverseViewProj;
    vec4 size;  // xy: camera image size
} camera;

layout(push_constant) uniform Push {
    mat4 lightViewProj;
    int maskBlock;   // view texels per mask texel, per side
    int resolution;  // view texels per side
} pc;

void main()
{
    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(pixel, ivec2(camera.size.xy)))) return;
    float depth = texelFetch(cameraDepth, pixel, 0).r;
    if (depth <= 0.0) return;
    vec2 ndc = (vec2(pixel) + 0.5) / camera.size.xy * 2.0 - 1.0;
    vec4 world = camera.inverseViewProj * vec4(ndc, depth, 1.0);
    if (world.w == 0.0) return;
    vec4 clip = pc.lightViewProj * vec4(world.xyz / world.w, 1.0);
    if (clip.w <= 0.0) return;
    vec3 light = clip.xyz / clip.w;
    if (any(greaterThan(abs(light.xy), vec2(1.0))) || light.z < 0.0 || light.z > 1.0) return;
    ivec2 texel = clamp(ivec2((light.xy * 0.5 + 0.5) * float(pc.resolution)), ivec2(0), ivec2(pc.resolution - 1));
    imageStore(receiverMask, texel / pc.maskBlock, vec4(1.0));
}
