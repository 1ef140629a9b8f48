// The lean G-buffer's precision (shaders/common/gbuffer.glsl): world positions rebuilt
// from the camera depth, against the surface that each pixel's centre ray hits (a CPU
// ray cast in double precision), at scene scales 1e-3, 1 and 1e5 and at a near/far
// ratio beyond 1e6.
//
// What counts for shadows is the distance from the rebuilt point to the surface (a
// receiver above or below its caster's surface); along the surface, a point may slide
// by a fraction of a pixel at grazing angles (the rasterizer snaps vertices to 1/256
// pixel, llvmpipe, and the depth is the snapped triangle's), which moves no shadow.
#include "RayCast.h"
#include "TestConfigs.h"
#include "TestContext.h"

#include "penumbra/config/Config.h"
#include "penumbra/frame/FrameRenderer.h"
#include "penumbra/render/Projection.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>

using namespace penumbra;

namespace {

// The bound the techniques' receivers allow for (kGBufferRelativeError in
// common/gbuffer.glsl): a rebuilt position p lies within 5e-7 · (|p - eye| + |p|) of the
// surface.
constexpr double kRelativeBound = 5e-7;

struct PrecisionCase {
    std::string name;
    float scale = 1.0f;
    float nearWorld = 0.0f;  // > 0: the camera's near plane (1e-5: the view spans 3.5e6 of it)
};

std::ostream& operator<<(std::ostream& os, const PrecisionCase& c) { return os << c.name; }

class GBufferPrecision : public test::GpuTest, public ::testing::WithParamInterface<PrecisionCase> {};

TEST_P(GBufferPrecision, RebuiltPositionsLieOnTheSurfaceWithinTheStatedBound)
{
    const PrecisionCase& c = GetParam();
    config::RenderConfig cfg = test::defaultTestConfig();
    cfg.width = 160;
    cfg.height = 90;
    for (auto& [name, value] : cfg.scene.parts[0].params)
        if (name == "sphere_segments") value = "12";  // a cheaper ray cast; the same depths
    test::scaleConfig(cfg, c.scale);
    if (c.nearWorld > 0.0f) cfg.camera.nearWorld = c.nearWorld;
    const scene::Scene scene = config::buildScene(cfg.scene);
    frame::FrameRenderer renderer(*context, scene, cfg, test::plugins());
    renderer.renderFrame();
    const std::vector<float> positions = renderer.readPositions();

    const float aspect = float(cfg.width) / float(cfg.height);
    const glm::dmat4 unproject = glm::inverse(
        glm::dmat4(render::perspectiveReversedZ(glm::radians(cfg.camera.fovYDeg), aspect, cfg.camera.nearWorld)) *
        glm::dmat4(render::cameraView(cfg.camera)));
    const glm::dvec3 eye(cfg.camera.position);
    const test::RayCaster caster(scene);
    // The first hit along the ray through NDC (x, y); +inf when none.
    const auto hitAt = [&](double x, double y, glm::dvec3& point) {
        // Along the ray: x c0 + y c1 + c3 of the inverse (its w is 0; the eye, which a
        // near-plane point 1e-5 away would give only to a few digits, drops out).
        const glm::dvec3 dir = glm::normalize(x * glm::dvec3(unproject[0]) + y * glm::dvec3(unproject[1]) +
                                              glm::dvec3(unproject[3]));
        const double t = caster.closestHit(eye, dir);
        point = eye + dir * t;
        return t;
    };

    size_t checked = 0, nearEdges = 0, coverageDiffers = 0;
    double worst = 0.0, farthest = 0.0;
    for (uint32_t py = 0; py < cfg.height; ++py) {
        for (uint32_t px = 0; px < cfg.width; ++px) {
            const size_t i = size_t(py) * cfg.width + px;
            const double x = (px + 0.5) / cfg.width * 2.0 - 1.0, y = (py + 0.5) / cfg.height * 2.0 - 1.0;
            glm::dvec3 exact;
            const double t = hitAt(x, y, exact);
            const bool rasterHit = positions[4 * i + 3] != 0.0f;
            // Pixels whose centre lies within a quarter pixel of a depth edge or of the
            // geometry's outline: which side the rasterizer's edge rules take is no
            // question of precision.
            // Also where the hits half a pixel away are not on one plane with this one
            // (a crease between facets): the plane they give is the surface's normal.
            bool edge = false;
            glm::dvec3 q[4];
            const glm::dvec2 offsets[4] = {{0.5, 0.0}, {-0.5, 0.0}, {0.0, 0.5}, {0.0, -0.5}};
            for (int k = 0; k < 4; ++k) {
                const double tq = hitAt(x + offsets[k].x * 2.0 / cfg.width, y + offsets[k].y * 2.0 / cfg.height, q[k]);
                edge = edge || std::isinf(tq) != std::isinf(t) || std::abs(tq - t) > 0.05 * t;
            }
            glm::dvec3 normal(0.0);
            if (!edge) {
                normal = glm::normalize(glm::cross(q[0] - exact, q[2] - exact));
                for (int k = 0; k < 4; ++k)
                    edge = edge || std::abs(glm::dot(q[k] - exact, normal)) > 1e-6 * glm::length(q[k] - exact);
            }
            if (edge) {
                ++nearEdges;
                continue;
            }
            // Coverage is the rasterizer's (vertices snapped to 1/256 pixel): a pixel on a
            // surface's outline may go either way, which is no question of depth.
            if (rasterHit != !std::isinf(t)) ++coverageDiffers;
            if (!rasterHit || std::isinf(t)) continue;
            const glm::dvec3 p(positions[4 * i], positions[4 * i + 1], positions[4 * i + 2]);
            const double bound = kRelativeBound * (glm::length(p - eye) + glm::length(p));
            const double ratio = std::abs(glm::dot(p - exact, normal)) / bound;
            EXPECT_LE(ratio, 1.0) << c << ": pixel (" << px << ", " << py << ") rebuilt at (" << p.x << ", "
                                             << p.y << ", " << p.z << "), the ray hits (" << exact.x << ", " << exact.y
                                             << ", " << exact.z << ")";
            worst = std::max(worst, ratio);
            farthest = std::max(farthest, glm::length(p - eye));
            ++checked;
        }
    }
    EXPECT_GT(checked, size_t(cfg.width) * cfg.height / 3) << c;
    EXPECT_LT(nearEdges, size_t(cfg.width) * cfg.height / 8) << c;
    EXPECT_LE(coverageDiffers, size_t(cfg.width) * cfg.height / 1000) << c;
    if (c.nearWorld > 0.0f) {
        EXPECT_GT(farthest / cfg.camera.nearWorld, 1e6) << "the view must reach a million near distances";
    }
    std::printf("[ gbuffer  ] %s: worst distance to the surface = %.3g of the bound, over %zu pixels\n",
                c.name.c_str(), worst, checked);
}

INSTANTIATE_TEST_SUITE_P(Scales, GBufferPrecision,
                         ::testing::Values(PrecisionCase{"scale_1e-3", 1e-3f}, PrecisionCase{"scale_1", 1.0f},
                                           PrecisionCase{"scale_1e5", 1e5f}, PrecisionCase{"near_far_1e6", 1.0f, 1e-5f}),
                         [](const ::testing::TestParamInfo<PrecisionCase>& info) {
                             std::string name = info.param.name;
                             std::replace(name.begin(), name.end(), '-', 'm');
                             return name;
                         });

} // namespace
