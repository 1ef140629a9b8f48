// Per-instance data shared by every pass that draws scene geometry. The draw's
// firstInstance is the instance index, so gl_InstanceIndex finds the row.
#ifndef PENUMBRA_SCENE_GLSL
#define PENUMBRA_SCENE_GLSL

struct InstanceData {
    mat4 model;
    mat4 normalMatrix;  // inverse-transpose of model (w column unused)
    vec4 baseColor;     // rgb albedo, a = alpha
};

#endif
