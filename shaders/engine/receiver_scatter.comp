#version 460
// visibility::ReceiverMaskBuilder, step 2: the receiver mask. The paper rasterises the visible
// receivers from the light and keeps the fragments that pass the reverse shadow test
// against the camera depth; the texels it keeps are those whose surface point a camera
// pixel sees. This pass marks the same texels from the camera's side: every camera pixel
// with geometry is unprojected from the camera depth and marks the texel of the light
// view it falls in. Exact (no depth tolerance), and one invocation per pixel instead of a
// reverse test per receiver fragment at the map's resolution, which on a CPU rasteriser
// cost more than the casters it saved (docs/culling.md).
//
// With RECEIVER_DEPTH defined (the view's technique compares with each receiver's own
// depth, CasterView::compareTapRadius) each pixel also lowers, in receiverDepth at the
// view's full resolution, the texel's farthest receiver depth to its own (atomic min of
// the bits of a non-negative float); engine/receiver_depth_min.comp then spreads it over
// the technique's taps.
//
// On a CPU device the host runs the same arithmetic instead (engine/src/visibility/
// ReceiverScatter.cpp, faster there): a change here belongs there too (the visibility test
// HostAndDeviceScattersGiveNonesImageAndCullAlike compares the two).
layout(local_size_x = 8, local_size_y = 8) in;

layout(binding = 0) uniform sampler2D cameraDepth;  // reversed-Z, 0 where nothing was drawn
// One word per mask texel, row by row, 0 where unmarked: host-visible, the host reads the
// marks where they are written (and dilates them).
layout(std430, binding = 1) writeonly buffer ReceiverMarks { uint receiverMarks[]; };
layout(std430, binding = 2) readonly buffer Camera {
    mat4 inverseViewProj;
    vec4 size;  // xy: camera image size
    vec4 eye;   // xyz: the camera's position (a far point along the view for orthographic cameras)
} camera;
#ifdef RECEIVER_DEPTH
layout(std430, binding = 3) coherent buffer ReceiverDepth { uint receiverDepth[]; };  // row by row, all ones
#endif

layout(push_constant) uniform Push {
    mat4 lightViewProj;
    int maskBlock;   // view texels per mask texel, per side
    int resolution;  // view texels per side
    int maskSize;    // mask texels per side
} pc;

#ifdef RECEIVER_DEPTH
// How far the point unprojected here may lie from the G-buffer's position of the same
// pixel, which the technique projects: both come from the same triangles at the same
// pixel centre, through fp32 depth, matrix inverses and interpolation, each good to a
// few 1e-7 of the coordinates' size. 1e-5 of it leaves ten times that.
const float kReconstructionRelative = 1e-5;

// |grad (row . p / w)| at p, for a row of the light's matrix: (row w - x row_w) / w^2.
float projectedGradient(vec3 row, vec3 rowW, float x, float w)
{
    return length(row * w - x * rowW) / (w * w);
}
#endif

// The camera's and the light's matrices are loaded first, and the pixel's tests are
// selected, not returned on: on llvmpipe a uniform value is loaded once per SIMD group
// only outside divergent control flow (docs/performance.md, "Uniform loads").
void main()
{
    mat4 inverseViewProj = camera.inverseViewProj;
    vec2 size = camera.size.xy;
    mat4 lightViewProj = pc.lightViewProj;
    int maskBlock = pc.maskBlock;
    int resolution = pc.resolution;
    int maskSize = pc.maskSize;
#ifdef RECEIVER_DEPTH
    vec3 eye = camera.eye.xyz;
#endif

    ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
    bool inImage = all(lessThan(pixel, ivec2(size)));
    pixel = min(pixel, ivec2(size) - 1);
    float depth = texelFetch(cameraDepth, pixel, 0).r;
    vec2 ndc = (vec2(pixel) + 0.5) / size * 2.0 - 1.0;
    vec4 world = inverseViewProj * vec4(ndc, depth, 1.0);
    vec3 p = world.xyz / (world.w != 0.0 ? world.w : 1.0);
    vec4 clip = lightViewProj * vec4(p, 1.0);
    vec3 light = clip.xyz / (clip.w > 0.0 ? clip.w : 1.0);
    bool inView = all(lessThanEqual(abs(light.xy), vec2(1.0))) && light.z >= 0.0 && light.z <= 1.0;
    bool receiver = inImage && depth > 0.0 && world.w != 0.0 && clip.w > 0.0 && inView;
    vec2 texelCoord = (light.xy * 0.5 + 0.5) * float(resolution);
    ivec2 texel = clamp(ivec2(texelCoord), ivec2(0), ivec2(resolution - 1));
    if (!receiver) return;
    ivec2 maskTexel = texel / maskBlock;
    receiverMarks[maskTexel.y * maskSize + maskTexel.x] = 1u;
#ifdef RECEIVER_DEPTH
    // The technique's receiver lies within `slack` of p: its depth is at least light.z
    // less the depth gradient times slack, and its texel within `spread` texels of p's.
    mat4 m = lightViewProj;
    vec3 rowX = vec3(m[0][0], m[1][0], m[2][0]), rowY = vec3(m[0][1], m[1][1], m[2][1]);
    vec3 rowZ = vec3(m[0][2], m[1][2], m[2][2]), rowW = vec3(m[0][3], m[1][3], m[2][3]);
    float slack = kReconstructionRelative * (length(p) + length(p - eye));
    float farthest = light.z - projectedGradient(rowZ, rowW, clip.z, clip.w) * slack - 4.0 / 16777216.0;
    uint bits = floatBitsToUint(max(farthest, 0.0));
    float texelsPerNdc = 0.5 * float(resolution);
    float spread = texelsPerNdc * slack *
                       max(projectedGradient(rowX, rowW, clip.x, clip.w), projectedGradient(rowY, rowW, clip.y, clip.w)) +
                   1.0 / 64.0;
    // A texel's worth of slack would mean a map finer than the camera's depth can place
    // (beyond 30,000 texels for a scene seen from its own size); the spread is capped at
    // one texel, which keeps the loop below at most 3 x 3.
    spread = min(spread, 1.0);
    ivec2 lo = clamp(ivec2(floor(texelCoord - spread)), ivec2(0), ivec2(resolution - 1));
    ivec2 hi = clamp(ivec2(floor(texelCoord + spread)), ivec2(0), ivec2(resolution - 1));
    for (int y = lo.y; y <= hi.y; ++y)
        for (int x = lo.x; x <= hi.x; ++x) {
            // Many pixels fall in one texel: the atomic only where it can still lower the
            // depth (values only decrease, so a stale read at most costs an atomic).
            uint i = uint(y * resolution + x);
            if (receiverDepth[i] > bits) atomicMin(receiverDepth[i], bits);
        }
#endif
}
