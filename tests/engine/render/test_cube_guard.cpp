// Cube maps' guard bands (render/ShadowMap.h guardTexels, render/Projection.h
// shadowFrusta's cubeHalfTan): a face widened beyond 90° keeps its axis, its texel density
// and its texel grid, so that the 90° part is drawn as before and the band continues it
// past the cube edge; and the band a kernel needs (kernelGuardTexels), with its guards.
// tests/techniques/test_cube_edges.cpp renders what the band is for.
#include "penumbra/render/Projection.h"
#include "penumbra/render/ShadowMap.h"

#include <gtest/gtest.h>

#include <glm/glm.hpp>

#include <cmath>
#include <limits>

using namespace penumbra;

namespace {

scene::Light rectLight()
{
    scene::Light light;
    light.type = scene::LightType::Rect;
    light.position = {0.3f, 2.0f, -0.2f};
    light.direction = {0.0f, -1.0f, 0.0f};
    light.sizeWorld = {0.5f, 0.5f};
    return light;
}

scene::Aabb groundBox() { return {{-5.0f, 0.0f, -5.0f}, {5.0f, 1.0f, 5.0f}}; }

glm::vec3 ndcOf(const glm::mat4& viewProj, glm::vec3 p)
{
    const glm::vec4 c = viewProj * glm::vec4(p, 1.0f);
    return glm::vec3(c) / c.w;
}

} // namespace

TEST(CubeGuard, WiderFacesKeepTheirAxesAndTexelGrid)
{
    const scene::Light light = rectLight();
    const auto plain = render::shadowFrusta(light, groundBox());
    ASSERT_EQ(plain.size(), 6u);
    constexpr int kResolution = 1024;
    for (int guard : {1, 65, 256}) {
        const float halfTan = float(kResolution + 2 * guard) / float(kResolution);
        const auto wide = render::shadowFrusta(light, groundBox(), nullptr, halfTan);
        ASSERT_EQ(wide.size(), 6u);
        for (size_t f = 0; f < 6; ++f) {
            SCOPED_TRACE(testing::Message() << "guard " << guard << ", face " << f);
            EXPECT_EQ(wide[f].view, plain[f].view) << "same axis and up";
            EXPECT_EQ(wide[f].nearWorld, plain[f].nearWorld);
            // A point on the 90° face's edge and one at its centre: NDC scaled by
            // 1 / halfTan, so that texel k of the 90° face is texel k + guard of the wide
            // one (the same grid, shifted by whole texels).
            for (glm::vec2 at : {glm::vec2(1.0f, 0.3f), glm::vec2(-1.0f, -1.0f), glm::vec2(0.0f, 0.0f)}) {
                const glm::mat4 toWorld = glm::inverse(plain[f].viewProj);
                glm::vec4 w = toWorld * glm::vec4(at, 0.5f, 1.0f);
                const glm::vec3 p = glm::vec3(w) / w.w;
                const glm::vec3 a = ndcOf(plain[f].viewProj, p), b = ndcOf(wide[f].viewProj, p);
                EXPECT_NEAR(b.x, a.x / halfTan, 1e-5f);
                EXPECT_NEAR(b.y, a.y / halfTan, 1e-5f);
                EXPECT_NEAR(b.z, a.z, 1e-6f) << "depth is the distance along the axis either way";
                const float texelPlain = (a.x * 0.5f + 0.5f) * kResolution;
                const float texelWide = (b.x * 0.5f + 0.5f) * (kResolution + 2 * guard);
                EXPECT_NEAR(texelWide, texelPlain + guard, 2e-3f);
            }
        }
    }
}

TEST(CubeGuard, OutOfRangeWideningsGiveNinetyDegrees)
{
    const scene::Light light = rectLight();
    const auto plain = render::shadowFrusta(light, groundBox());
    for (float halfTan : {0.0f, 0.5f, -2.0f, std::numeric_limits<float>::quiet_NaN()}) {
        const auto faces = render::shadowFrusta(light, groundBox(), nullptr, halfTan);
        for (size_t f = 0; f < faces.size(); ++f) EXPECT_EQ(faces[f].viewProj, plain[f].viewProj) << halfTan;
    }
    // Huge widenings stop below 180° (the projection stays finite).
    const auto widest = render::shadowFrusta(light, groundBox(), nullptr, std::numeric_limits<float>::infinity());
    for (const render::LightFrustum& f : widest) {
        EXPECT_TRUE(std::isfinite(f.proj[0][0]) && f.proj[0][0] > 0.0f);
        EXPECT_NEAR(f.proj[0][0], 1.0f / 16.0f, 1e-6f);
    }
}

TEST(CubeGuard, BandCoversTheReachPlusATexelUpToAQuarterFace)
{
    EXPECT_EQ(render::kernelGuardTexels(0.0f, 1024), 0u);
    EXPECT_EQ(render::kernelGuardTexels(-3.0f, 1024), 0u);
    EXPECT_EQ(render::kernelGuardTexels(std::numeric_limits<float>::quiet_NaN(), 1024), 0u);
    EXPECT_EQ(render::kernelGuardTexels(0.5f, 1024), 2u);
    EXPECT_EQ(render::kernelGuardTexels(64.0f, 1024), 65u);
    EXPECT_EQ(render::kernelGuardTexels(64.2f, 1024), 66u);
    EXPECT_EQ(render::kernelGuardTexels(256.0f, 1024), 257u);
    EXPECT_EQ(render::kernelGuardTexels(1024.0f, 1024), 257u) << "at most a quarter of the face";
    EXPECT_EQ(render::kernelGuardTexels(std::numeric_limits<float>::infinity(), 1024), 257u);
    EXPECT_EQ(render::kernelGuardTexels(5.0f, 16), 5u) << "a quarter of 16 texels, plus one";
}
