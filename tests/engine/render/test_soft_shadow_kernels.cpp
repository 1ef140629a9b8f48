// The PCSS framework's CPU side (render/ShadowMap.h): the light's size as the kernels take
// it, and how far their kernels can reach on a map, which bounds the casters that caster
// culling must keep. The reach must cover every radius penumbra_estimate.glsl can compute,
// and its guards must hold at the degenerate ends (light size 0 or inf, a face of texel 0,
// a near plane at 0).
#include "penumbra/render/ShadowMap.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

using namespace penumbra;

namespace {

// One perspective face: `texel` world per unit of distance, depths [near, far].
render::ShadowMapData perspectiveFace(float texel, float near, float far)
{
    render::ShadowMapData d;
    d.faceCount = 1;
    d.faces[0].texel = {texel, texel, 0.0f, 0.0f};
    d.faces[0].depthRange = {near, far, 0.0f, 0.0f};
    return d;
}

render::ShadowMapData orthographicFace(float texel, float near, float far)
{
    render::ShadowMapData d = perspectiveFace(texel, near, far);
    d.faces[0].depthRange.z = 1.0f;
    return d;
}

// penumbra_estimate.glsl's radii (before the clamp), for the sweep below.
float searchTexels(const render::ShadowFaceData& f, bool orthographic, float lightSize, float dReceiver)
{
    const float near = f.depthRange.x;
    const float extent = orthographic ? (dReceiver - near) * lightSize : (lightSize / near) * ((dReceiver - near) / dReceiver);
    return 0.5f * extent / f.texel.x;
}
float filterTexels(const render::ShadowFaceData& f, bool orthographic, float lightSize, float dReceiver, float dBlocker)
{
    const float gap = std::max(dReceiver - dBlocker, 0.0f);
    const float width = orthographic ? gap * lightSize : (gap / dReceiver) * (lightSize / std::max(dBlocker, f.depthRange.x));
    return 0.5f * width / f.texel.x;
}

} // namespace

TEST(SoftShadowKernels, ReachCoversEveryRadiusTheShadersCompute)
{
    for (bool orthographic : {false, true}) {
        for (float near : {1e-3f, 0.1f, 2.0f}) {
            const float far = near * 50.0f + 10.0f, texel = orthographic ? 0.01f : 2.0f / 1024.0f;
            const render::ShadowMapData d = orthographic ? orthographicFace(texel, near, far) : perspectiveFace(texel, near, far);
            for (float lightSize : {1e-3f, 0.5f, 4.0f}) {
                const float reach = render::softShadowKernelReach(d, lightSize);
                SCOPED_TRACE(testing::Message() << (orthographic ? "orthographic" : "perspective") << ", near " << near
                                                << ", light " << lightSize);
                float widest = 0.0f;
                for (int r = 0; r <= 16; ++r) {
                    const float dReceiver = near + (far - near) * float(r) / 16.0f;
                    widest = std::max(widest, searchTexels(d.faces[0], orthographic, lightSize, dReceiver));
                    for (int b = 0; b <= r; ++b) {
                        const float dBlocker = near + (far - near) * float(b) / 16.0f;
                        widest = std::max(widest, filterTexels(d.faces[0], orthographic, lightSize, dReceiver, dBlocker));
                    }
                }
                EXPECT_GE(reach * (1.0f + 1e-5f), widest);
                // And not wildly more: the bound is the light seen from the near plane.
                EXPECT_LE(reach, 2.0f * widest + 1e-3f);
            }
        }
    }
}

TEST(SoftShadowKernels, ReachGuardsTheDegenerateEnds)
{
    const render::ShadowMapData d = perspectiveFace(2.0f / 512.0f, 0.1f, 20.0f);
    EXPECT_EQ(render::softShadowKernelReach(d, 0.0f), 0.0f) << "a light of size 0: one compare";
    EXPECT_TRUE(std::isinf(render::softShadowKernelReach(d, std::numeric_limits<float>::infinity())))
        << "an infinite light reaches without bound; the technique's limit clamps it";
    EXPECT_EQ(render::softShadowKernelReach(perspectiveFace(0.0f, 0.1f, 20.0f), 1.0f), 0.0f) << "texel 0";
    EXPECT_EQ(render::softShadowKernelReach(perspectiveFace(NAN, 0.1f, 20.0f), 1.0f), 0.0f) << "texel NaN";
    EXPECT_TRUE(std::isinf(render::softShadowKernelReach(perspectiveFace(0.01f, 0.0f, 20.0f), 1.0f)))
        << "a near plane at 0";
    EXPECT_EQ(render::softShadowKernelReach(orthographicFace(0.01f, 5.0f, 5.0f), 1.0f), 0.0f) << "no depth range";
    render::ShadowMapData none = d;
    none.faceCount = 0;
    EXPECT_EQ(render::softShadowKernelReach(none, 1.0f), 0.0f);
    render::ShadowMapData cube = d;
    cube.faceCount = 6;
    for (uint32_t f = 1; f < 6; ++f) cube.faces[f] = d.faces[0];
    cube.faces[4].depthRange.x = 0.01f;  // the widest face counts
    EXPECT_FLOAT_EQ(render::softShadowKernelReach(cube, 1.0f), 0.5f * (1.0f / 0.01f) / (2.0f / 512.0f));
}

TEST(SoftShadowKernels, LightSizeFollowsTheLightAndItsOverride)
{
    scene::Light rect;
    rect.type = scene::LightType::Rect;
    rect.sizeWorld = {4.0f, 1.0f};
    EXPECT_FLOAT_EQ(render::softShadowLightSize(rect, -1.0f), 2.0f) << "the side of the square of equal area";
    EXPECT_FLOAT_EQ(render::softShadowLightSize(rect, 0.25f), 0.25f);
    scene::Light spot;
    EXPECT_EQ(render::softShadowLightSize(spot, -1.0f), 0.0f) << "a spot light has no size of its own";
    scene::Light sun;
    sun.type = scene::LightType::Directional;
    sun.angularDiameterDeg = 1000.0f;
    EXPECT_TRUE(std::isfinite(render::softShadowLightSize(sun, -1.0f))) << "clamped below 180°";
}
