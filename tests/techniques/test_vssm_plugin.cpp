// The vssm plugin (plugins/vssm): its summed-area table's precision against exact sums
// at 512^2, 2048^2 and 4096^2 (run on the GPU, without the plugin loaded), then the
// technique end to end through frame::FrameRenderer: light size 0 against the hard
// plugin, every light type against rays from the light away from penumbrae, the
// penumbra scene against the exact soft shadow for every subdivision variant,
// overlapping blockers (the incorrectly-lit area that subdivision removes), the debug
// views, and the extremes: a 4096^2 map, a huge light, a blocker touching its receiver,
// grazing light, scene scales 1e-3 and 1e5.
#include "PenumbraMeasure.h"
#include "PluginFrame.h"
#include "RayCastAgreement.h"
#include "TestConfigs.h"
#include "TestContext.h"
#include "TestPaths.h"  // support/: the build tree's paths

#include "penumbra/config/Config.h"
#include "penumbra/core/Error.h"
#include "penumbra/gpu/Barrier.h"
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/gpu/Resources.h"
#include "penumbra/gpu/ShaderCompiler.h"
#include "penumbra/plugin/PluginRegistry.h"
#include "penumbra/render/ShadowMap.h"
#include "penumbra/scene/Generators.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <random>
#include <string>

using namespace penumbra;
namespace fs = std::filesystem;

// ---------------------------------------------------------------------------------
// The summed-area table (plugins/vssm/sat.glsl, sat.comp).

namespace {

// Depths are k 2^-24 with k < 2^23 (t in [0, 0.5)): the map stores NDC depth 1 - t,
// which is exact in fp32 there, and the shader's t = 1 - NDC is exact too, so the
// reference sums below are exact integers.
constexpr double kDepthUnit = 1.0 / 16777216.0;  // 2^-24

// A map with what a shadow map has: a tilted receiver plane with fine relief (the
// variances Chebyshev must resolve are this small), blockers much nearer the light, and
// empty texels at the far end.
std::vector<uint32_t> depthUnits(uint32_t size, uint32_t seed)
{
    std::mt19937 rng(seed);
    std::uniform_int_distribution<uint32_t> relief(0, 2000);  // ~1e-4 of t
    std::vector<uint32_t> k(size_t(size) * size);
    struct Rect {
        uint32_t x0, y0, x1, y1, depth;
    };
    std::vector<Rect> blockers;
    std::uniform_int_distribution<uint32_t> at(0, size - 1), extent(1, std::max(size / 16, 2u));
    for (int i = 0; i < 40; ++i) {
        const uint32_t x = at(rng), y = at(rng);
        blockers.push_back({x, y, std::min(x + extent(rng), size), std::min(y + extent(rng), size),
                            uint32_t(0.05 / kDepthUnit) + relief(rng) * 100});
    }
    for (uint32_t y = 0; y < size; ++y)
        for (uint32_t x = 0; x < size; ++x) {
            uint32_t v = uint32_t((0.3 + 0.1 * double(x + y) / double(2 * size)) / kDepthUnit) + relief(rng);
            if ((x / 97 + y / 89) % 11 == 0) v = (1u << 23) - 1;  // nothing drawn there: far
            for (const Rect& r : blockers)
                if (x >= r.x0 && x < r.x1 && y >= r.y0 && y < r.y1) v = r.depth;
            k[size_t(y) * size + x] = v;
        }
    return k;
}

// Exact moments of the integer box [x0, x0 + w) x [y0, y0 + h).
struct ExactMoments {
    double mean, meanSquare, variance;
};

ExactMoments exactBox(const std::vector<uint32_t>& k, uint32_t size, uint32_t x0, uint32_t y0, uint32_t w, uint32_t h)
{
    __int128 sum = 0, squares = 0;
    for (uint32_t y = y0; y < y0 + h; ++y)
        for (uint32_t x = x0; x < x0 + w; ++x) {
            const __int128 v = k[size_t(y) * size + x];
            sum += v;
            squares += v * v;
        }
    const __int128 n = __int128(w) * h;
    const double unitSquared = kDepthUnit * kDepthUnit;
    return {double(sum) / double(n) * kDepthUnit, double(squares) / double(n) * unitSquared,
            double(n * squares - sum * sum) / double(n * n) * unitSquared};
}

// The error of each moment, worst over the boxes.
struct BoxErrors {
    double mean = 0.0, meanSquare = 0.0, variance = 0.0;
};

class VssmSat : public test::GpuTest, public ::testing::WithParamInterface<uint32_t> {
protected:
    // Builds the plugin's table over `k` (size x size) and queries `boxes` (lo.xy, hi.xy).
    std::vector<glm::dvec4> query(const std::vector<uint32_t>& k, uint32_t size, const std::vector<glm::vec4>& boxes)
    {
        std::vector<float> ndc(k.size());
        for (size_t i = 0; i < k.size(); ++i) ndc[i] = float(1.0 - double(k[i]) * kDepthUnit);
        const gpu::Image depth = gpu::uploadImage(*context, size, size, VK_FORMAT_D32_SFLOAT,
                                                  std::as_bytes(std::span(ndc)), "sat_test.depth");
        // One orthographic face over depths [0, 1]: t = 1 - NDC.
        render::ShadowMapData data;
        data.faceCount = 1;
        data.faceTexels = float(size);
        data.faces[0].depthRange = {0.0f, 1.0f, 1.0f, 0.0f};
        gpu::Buffer mapData(*context, sizeof(data), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true, "sat_test.map");
        std::memcpy(mapData.mapped(), &data, sizeof(data));
        const gpu::Image sat(*context, {size, size, VK_FORMAT_R32G32B32A32_UINT, VK_IMAGE_USAGE_STORAGE_BIT,
                                        "sat_test.sat"});
        gpu::Buffer boxBuffer(*context, boxes.size() * sizeof(glm::vec4), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true,
                              "sat_test.boxes");
        std::memcpy(boxBuffer.mapped(), boxes.data(), boxes.size() * sizeof(glm::vec4));
        gpu::Buffer results(*context, boxes.size() * sizeof(glm::dvec4), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true,
                            "sat_test.results");

        const gpu::ShaderCompiler compiler({penumbra::test::sourceDir() / "plugins/vssm",
                                            penumbra::test::testDataDir() / "shaders", gpu::engineShaderDir()});
        gpu::ComputePipelineDesc scanDesc;
        scanDesc.name = "sat_test.scan";
        scanDesc.shader = "sat.comp";
        scanDesc.pushConstantBytes = 3 * sizeof(int32_t);
        const gpu::Pipeline scan(*context, compiler, scanDesc);
        gpu::ComputePipelineDesc probeDesc;
        probeDesc.name = "sat_test.probe";
        probeDesc.shader = "sat_probe.comp";
        probeDesc.pushConstantBytes = 3 * sizeof(int32_t);
        const gpu::Pipeline probe(*context, compiler, probeDesc);
        const gpu::Sampler sampler = gpu::createSampler(*context, VK_FILTER_NEAREST, VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE);

        context->submitAndWait([&](VkCommandBuffer cmd) {
            gpu::transition(cmd, sat, gpu::access::kUndefined, gpu::access::kComputeWrite);
            scan.bind(cmd);
            gpu::DescriptorPush()
                .sampledImage("shadowDepth", depth, sampler)
                .storageImage("satImage", sat)
                .storageBuffer("shadowMapBuffer", mapData)
                .push(
                *context, cmd, scan);
            int32_t push[3] = {int32_t(size), int32_t(size), 0};
            scan.pushConstants(cmd, push, sizeof(push));
            scan.dispatchOver(cmd, size);
            gpu::memoryBarrier(cmd, gpu::access::kComputeStorageWrite, gpu::access::kComputeStorageReadWrite);
            push[2] = 1;
            scan.pushConstants(cmd, push, sizeof(push));
            scan.dispatchOver(cmd, size);
            gpu::memoryBarrier(cmd, gpu::access::kComputeStorageWrite, gpu::access::kComputeStorageReadWrite);
            probe.bind(cmd);
            gpu::DescriptorPush()
                .storageImage("satImage", sat)
                .storageBuffer("Boxes", boxBuffer)
                .storageBuffer("Results", results)
                .push(
                *context, cmd, probe);
            const int32_t probePush[3] = {int32_t(size), int32_t(size), int32_t(boxes.size())};
            probe.pushConstants(cmd, probePush, sizeof(probePush));
            probe.dispatchOver(cmd, uint32_t(boxes.size()));
        });
        const auto* out = static_cast<const glm::dvec4*>(results.mapped());
        return {out, out + boxes.size()};
    }
};

// Boxes of `side` texels at random places, and at the far corner, where the table's
// entries are largest.
std::vector<glm::uvec2> boxCorners(uint32_t size, uint32_t side, uint32_t seed)
{
    std::mt19937 rng(seed);
    std::uniform_int_distribution<uint32_t> at(0, size - side);
    std::vector<glm::uvec2> corners = {{size - side, size - side}, {0, size - side}, {size - side, 0}, {0, 0}};
    for (int i = 0; i < 400; ++i) corners.push_back({at(rng), at(rng)});
    return corners;
}

} // namespace

TEST_P(VssmSat, BoxMomentsMatchExactSums)
{
    const uint32_t size = GetParam();
    const std::vector<uint32_t> k = depthUnits(size, size);
    for (uint32_t side : {3u, 33u}) {
        const std::vector<glm::uvec2> corners = boxCorners(size, side, side);
        std::vector<glm::vec4> boxes;
        for (const glm::uvec2 c : corners) boxes.push_back({float(c.x), float(c.y), float(c.x + side), float(c.y + side)});
        const std::vector<glm::dvec4> got = query(k, size, boxes);
        BoxErrors worst;
        double smallestVariance = 1.0;
        for (size_t i = 0; i < corners.size(); ++i) {
            const ExactMoments e = exactBox(k, size, corners[i].x, corners[i].y, side, side);
            worst.mean = std::max(worst.mean, std::abs(got[i].x - e.mean));
            worst.meanSquare = std::max(worst.meanSquare, std::abs(got[i].y - e.meanSquare));
            worst.variance = std::max(worst.variance, std::abs(got[i].z - e.variance));
            EXPECT_EQ(got[i].w, double(side) * side);
            if (e.variance > 0.0) smallestVariance = std::min(smallestVariance, e.variance);
        }
        // Each texel's t and t^2 are rounded to 2^-31 once (sat.glsl): the means are
        // within 2^-32 (2.3e-10), E(t^2) within 2^-32 plus 2 t 2^-32 for t < 0.5, the
        // variance within their sum plus 2 E(t) 2^-32: under 1e-9. That is 1/1000 of
        // the vsm plugin's default least variance (1e-6) and far below the relief's
        // variances here (about 1e-8 on the plane's boxes).
        SCOPED_TRACE(fmt::format("{}^2, {} x {} boxes", size, side, side));
        EXPECT_LT(worst.mean, 2.4e-10);
        EXPECT_LT(worst.meanSquare, 5e-10);
        EXPECT_LT(worst.variance, 1e-9);
        EXPECT_LT(smallestVariance, side == 3 ? 1e-7 : 1e-5) << "the map has boxes with variances this small";
        RecordProperty(fmt::format("variance_error_{}_{}", size, side), fmt::format("{:.3g}", worst.variance));
    }
}

INSTANTIATE_TEST_SUITE_P(Vssm, VssmSat, ::testing::Values(512u, 2048u, 4096u),
                         [](const ::testing::TestParamInfo<uint32_t>& info) { return std::to_string(info.param); });

TEST_F(VssmSat, FractionalBoxesIntegrateTheMap)
{
    // Kernels are not texel-aligned: a box with fractional edges weighs each texel by
    // the part of it inside (the table read bilinearly).
    const uint32_t size = 64;
    const std::vector<uint32_t> k = depthUnits(size, 5);
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> at(0.0f, 40.0f), extent(0.3f, 20.0f);
    std::vector<glm::vec4> boxes;
    for (int i = 0; i < 200; ++i) {
        const glm::vec2 lo{at(rng), at(rng)};
        boxes.push_back({lo, lo + glm::vec2(extent(rng), extent(rng))});
    }
    const std::vector<glm::dvec4> got = query(k, size, boxes);
    for (size_t i = 0; i < boxes.size(); ++i) {
        const glm::vec4 b = boxes[i];
        long double sum = 0, squares = 0, area = 0;
        for (uint32_t y = uint32_t(b.y); y < std::min(uint32_t(std::ceil(b.w)), size); ++y)
            for (uint32_t x = uint32_t(b.x); x < std::min(uint32_t(std::ceil(b.z)), size); ++x) {
                const long double wx = std::min<long double>(b.z, x + 1) - std::max<long double>(b.x, x);
                const long double wy = std::min<long double>(b.w, y + 1) - std::max<long double>(b.y, y);
                const long double t = k[size_t(y) * size + x] * (long double)kDepthUnit;
                sum += wx * wy * t;
                squares += wx * wy * t * t;
                area += wx * wy;
            }
        const long double mean = sum / area, variance = squares / area - mean * mean;
        EXPECT_NEAR(got[i].w, double(area), 1e-5 * double(area)) << i;
        EXPECT_NEAR(got[i].x, double(mean), 1e-6) << i;
        EXPECT_NEAR(got[i].z, double(variance), 1e-6 * std::max(1.0, double(variance))) << i;
    }
}

TEST(VssmSatCpu, Fp32PrefixSumsWouldSwampTheVariance)
{
    // Why the table is not fp32 (sat.glsl): the same 3 x 3 boxes from an fp32 table of
    // a 2048^2 map are off in their variance by more than any variance Chebyshev must
    // resolve. (CPU sums in the order a row-then-column scan adds them.)
    const uint32_t size = 2048;
    const std::vector<uint32_t> k = depthUnits(size, size);
    std::vector<float> s1(k.size()), s2(k.size());
    for (uint32_t y = 0; y < size; ++y) {
        float r1 = 0.0f, r2 = 0.0f;
        for (uint32_t x = 0; x < size; ++x) {
            const float t = float(k[size_t(y) * size + x] * kDepthUnit);
            r1 += t;
            r2 += t * t;
            s1[size_t(y) * size + x] = r1;
            s2[size_t(y) * size + x] = r2;
        }
    }
    for (uint32_t x = 0; x < size; ++x)
        for (uint32_t y = 1; y < size; ++y) {
            s1[size_t(y) * size + x] += s1[size_t(y - 1) * size + x];
            s2[size_t(y) * size + x] += s2[size_t(y - 1) * size + x];
        }
    double worst = 0.0;
    for (const glm::uvec2 c : boxCorners(size, 3, 3)) {
        if (c.x == 0 || c.y == 0) continue;
        auto box = [&](const std::vector<float>& s) {
            const auto at = [&](uint32_t x, uint32_t y) { return s[size_t(y) * size + x]; };
            return (at(c.x + 2, c.y + 2) - at(c.x - 1, c.y + 2) - at(c.x + 2, c.y - 1) + at(c.x - 1, c.y - 1)) / 9.0f;
        };
        const float mean = box(s1);
        const double variance = double(box(s2)) - double(mean) * mean;
        worst = std::max(worst, std::abs(variance - exactBox(k, size, c.x, c.y, 3, 3).variance));
    }
    EXPECT_GT(worst, 1e-4) << "fp32 tables lose the variance at 2048^2";
}

// ---------------------------------------------------------------------------------
// The technique.

namespace {

// V counts as 0 or 1 within this away from penumbrae. Chebyshev's bound is an upper
// bound, so VSSM bleeds light as VSM does wherever a sub-kernel in front of the receiver
// holds blockers at several depths (its variance is then large against the distance to
// the receiver): the subdivision only splits kernels whose mean lies behind the
// receiver (paper Algorithm 2). Measured on the default scene, max radii 8 texels: up to
// 1.6e-4 in the umbrae of tilted blockers (spot, directional), 0.03 (rect, disk) and
// 0.29 (point, a pixel between two boxes) for mixed, about the same for none.
constexpr float kAgreementTolerance = 0.35f;

struct VssmSettings : test::KernelSettings {
    std::string subdivision = "mixed";
};

void applyVssm(config::LightConfig& light, const VssmSettings& s)
{
    nlohmann::json params = s.params();
    params["subdivision"] = s.subdivision;
    test::setShadow(light, "vssm", params);
}

class VssmTest : public test::TechniqueTest<VssmSettings, applyVssm> {
protected:
    // Against rays from the light's centre, away from penumbrae: as far as the kernels
    // reach, plus two texels, all lit or all shadowed in the centre's view.
    void expectRayCastAgreement(const std::vector<float>& v, const VssmSettings& s, const std::string& label)
    {
        PluginGpuTest::expectRayCastAgreement(v, s.bandTexels(), kAgreementTolerance, label);
    }
};

using test::LightCase;

class VssmLightTypes : public VssmTest, public ::testing::WithParamInterface<std::tuple<LightCase, const char*>> {};

} // namespace

TEST_P(VssmLightTypes, MatchesRayCastAwayFromPenumbrae)
{
    const auto& [c, subdivision] = GetParam();
    config::RenderConfig cfg = test::defaultTestConfig();
    test::setLightType(cfg.lights[0], c.type);
    if (c.type == scene::LightType::Directional) cfg.lights[0].light.angularDiameterDeg = 2.0f;
    VssmSettings s;
    s.lightSize = c.lightSize;
    s.resolution = c.resolution;
    s.subdivision = subdivision;
    const std::vector<float> v = renderWith(cfg, s);
    expectRayCastAgreement(v, s, std::string(c.name) + " " + subdivision);
    size_t soft = 0;
    for (float x : v) soft += x > 0.02f && x < 0.98f;
    EXPECT_GT(soft, 200u) << "a light with a size casts penumbrae";
}

INSTANTIATE_TEST_SUITE_P(Vssm, VssmLightTypes,
                         ::testing::Combine(::testing::Values(LightCase{"spot", scene::LightType::Spot, 0.6},
                                                              LightCase{"directional", scene::LightType::Directional,
                                                                        -1.0, 2048},
                                                              LightCase{"point", scene::LightType::Point, 0.4},
                                                              LightCase{"rect", scene::LightType::Rect, -1.0},
                                                              LightCase{"disk", scene::LightType::Disk, -1.0}),
                                            ::testing::Values("mixed", "none")),
                         [](const ::testing::TestParamInfo<std::tuple<LightCase, const char*>>& info) {
                             return std::string(std::get<0>(info.param).name) + "_" + std::get<1>(info.param);
                         });

TEST_F(VssmTest, ZeroSizeEqualsTheHardShadow)
{
    // Light size 0: hard's one nearest compare against the same reference depth.
    for (const char* bias : {"receiver_plane", "slope"}) {
        config::RenderConfig cfg = test::defaultTestConfig();
        VssmSettings s;
        s.lightSize = 0.0;
        s.biasMode = bias;
        const std::vector<float> vssm = renderWith(cfg, s);

        config::ShadowSettings& hard = cfg.lights[0].shadow;
        hard = {};
        hard.technique = "hard";
        hard.required = true;
        hard.setParam("bias_mode", bias, "test");
        hard.setParam("filter", "none", "test");
        hard.setParam("resolution", s.resolution, "test");
        render(cfg, config::buildScene(cfg.scene));
        const std::vector<float> reference = frame->renderer.readVisibility(0);
        size_t differ = 0, shadowed = 0;
        for (size_t i = 0; i < vssm.size(); ++i) {
            differ += std::abs(vssm[i] - reference[i]) > 1e-6f;
            shadowed += reference[i] == 0.0f;
        }
        EXPECT_EQ(differ, 0u) << bias << ": pixels where |V_vssm - V_hard| > 1e-6";
        EXPECT_GT(shadowed, vssm.size() / 50) << "the scene has shadows to compare";
    }
}

// ---------------------------------------------------------------------------------
// The penumbra scene against the exact soft shadow, every variant.

namespace {

VssmSettings penumbraVssm(const char* subdivision)
{
    VssmSettings s;
    s.maxSearchTexels = 64.0;
    s.maxFilterTexels = 64.0;
    s.subdivision = subdivision;
    return s;
}

class VssmPenumbra : public VssmTest, public ::testing::WithParamInterface<const char*> {
protected:
    test::PenumbraWidths measure(const test::PenumbraSetup& p)
    {
        const std::vector<float> v = renderWith(test::penumbraConfig(p), penumbraVssm(GetParam()),
                                                scene::generatePenumbra(test::penumbraParams(p)));
        return test::measurePenumbra(*frame, v, p);
    }
};

} // namespace

TEST_P(VssmPenumbra, WidthGrowsWithLightSizeAndFollowsTheExactPenumbra)
{
    double previous = 0.0;
    for (float side : {0.25f, 0.5f, 1.0f}) {
        test::PenumbraSetup p;
        p.lightSide = side;
        const test::PenumbraWidths w = measure(p);
        SCOPED_TRACE(fmt::format("{}, light side {}", GetParam(), side));
        EXPECT_GT(w.technique, 1.5 * previous) << "doubling the light widens the penumbra";
        // One plate, one blocker depth: eq. 4 gives it exactly, and the box filter over
        // the penumbra kernel ramps over its whole width, as the square light does.
        EXPECT_GT(w.technique, 0.7 * w.exact) << "exact " << w.exact;
        EXPECT_LT(w.technique, 1.2 * w.exact) << "exact " << w.exact;
        EXPECT_LT(w.rmse, 0.05) << "RMSE against the exact visibility";
        RecordProperty(fmt::format("rmse_side_{}", side), fmt::format("{:.4f}", w.rmse));
        previous = w.technique;
    }
}

INSTANTIATE_TEST_SUITE_P(Vssm, VssmPenumbra, ::testing::Values("none", "uniform", "adaptive", "mixed"));

// ---------------------------------------------------------------------------------
// Overlapping blockers at different depths (the paper's Fig. 3 and 9, as numbers).
// test::platformScene(): a pillar with a plate 0.2 above its top, under a 1 x 1 rect light
// 3 above the top. The plate's umbra covers most of the top. The kernels there (up to 64
// texels, about 0.4 m) mostly see the ground a metre below, behind the receiver, so a
// kernel's mean depth lies behind the receiver although the plate covers part of it: the
// non-planar case, which SAVSM-like lookups (subdivision none) take as lit. The camera
// looks straight down on the top from below the plate.

namespace {

// A pixel on the pillar's top (y = 1).
bool onPlatformTop(const test::RenderedFrame& frame, size_t pixel)
{
    return frame.hasGeometry(pixel) && std::abs(frame.positions[4 * pixel + 1] - 1.0f) < 1e-3f;
}

} // namespace

TEST_F(VssmTest, SubdivisionRemovesTheIncorrectlyLitAreaOfOverlappingBlockers)
{
    config::RenderConfig cfg = test::platformConfig();
    cfg.lights[0].shadow = {};
    cfg.lights[0].shadow.technique = "reference";
    cfg.lights[0].shadow.required = true;
    cfg.lights[0].shadow.setParam("cache", false, "test");
    cfg.lights[0].shadow.setParam("samples", 256, "test");
    render(cfg, test::platformScene());
    const std::vector<float> reference = frame->checkedVisibility();

    std::map<std::string, size_t> incorrectlyLit;
    size_t shadowedTop = 0;
    for (const char* subdivision : {"none", "uniform", "adaptive", "mixed"}) {
        VssmSettings s;
        s.maxSearchTexels = 64.0;
        s.maxFilterTexels = 64.0;
        s.subdivision = subdivision;
        const std::vector<float> v = renderWith(test::platformConfig(), s, test::platformScene());
        size_t wrong = 0, top = 0;
        double squared = 0.0;
        shadowedTop = 0;
        for (size_t i = 0; i < v.size(); ++i) {
            if (!onPlatformTop(*frame, i)) continue;
            ++top;
            squared += (v[i] - reference[i]) * (v[i] - reference[i]);
            if (reference[i] >= 0.5f) continue;
            ++shadowedTop;
            wrong += v[i] >= 0.9f;  // shadowed by the rays, lit by the technique
        }
        incorrectlyLit[subdivision] = wrong;
        EXPECT_GT(top, v.size() / 4) << "the camera sees the pillar's top";
        RecordProperty(fmt::format("incorrectly_lit_{}", subdivision), std::to_string(wrong));
        RecordProperty(fmt::format("rmse_top_{}", subdivision), fmt::format("{:.4f}", std::sqrt(squared / double(top))));
    }
    EXPECT_GT(shadowedTop, 500u) << "the plate shadows the pillar's top";
    EXPECT_GT(incorrectlyLit["none"], shadowedTop / 10) << "without subdivision the umbra at the edge is lit";
    // Measured: none 56,160; uniform, adaptive and mixed 0 (adaptive and mixed 2,160 while
    // the quad-tree handed every node in front of the receiver to Chebyshev).
    for (const char* subdivision : {"uniform", "adaptive", "mixed"})
        EXPECT_LT(incorrectlyLit[subdivision], incorrectlyLit["none"] / 100) << subdivision;
}

// ---------------------------------------------------------------------------------
// Extremes and guards.

TEST_F(VssmTest, NoBlockerIsExactlyLitAtGrazingAngles)
{
    // A plane alone under a directional light at 60, 85 and 89 degrees from its normal
    // (1 degree wide, so all of it stays above the horizon): the HSM or the receiver
    // plane keeps the plane from finding itself as a blocker, so every pixel is exactly 1.
    for (float degrees : {60.0f, 85.0f, 89.0f}) {
        config::RenderConfig cfg = test::planeUnderDirectionalLightConfig(degrees);
        cfg.lights[0].light.angularDiameterDeg = 1.0f;
        VssmSettings s;
        s.maxSearchTexels = 64.0;
        s.maxFilterTexels = 64.0;
        const std::vector<float> v = renderWith(cfg, s, test::planeScene());
        expectExactlyLitWhereGeometry(v, fmt::format("{} degrees", degrees));
    }
}

TEST_F(VssmTest, HugeLightIsClampedToTheMaximumRadii)
{
    // A spot light of 1e9 world units: the kernels stop at their maximum half-widths, so
    // penumbrae stay that narrow (agreement with the rays beyond them).
    VssmSettings s;
    s.lightSize = 1e9;
    const std::vector<float> v = renderWith(test::defaultTestConfig(), s);
    expectRayCastAgreement(v, s, "light size 1e9");
}

TEST_F(VssmTest, BlockerTouchingTheReceiverCastsAHardShadow)
{
    // At the box's foot the blocker is at the receiver: t - z_occ < contact_epsilon, so
    // the contact PCF takes over with a kernel of half a texel or so, and the ground
    // right behind the foot is umbra, with no division by zero.
    VssmSettings s;
    s.maxSearchTexels = 64.0;
    s.maxFilterTexels = 64.0;
    const std::vector<float> v = renderWith(test::boxOnGroundConfig(), s, test::boxOnGroundScene());
    const double texel = 2.0 * 3.0 / 1024.0;  // a texel of the cube face on the ground, at most
    const test::FootShadow foot = test::footShadow(*frame, v, texel, 0.01f);
    EXPECT_GT(foot.pixels, 100u);
    EXPECT_EQ(foot.notUmbra, 0u) << "ground pixels right behind the foot that are not umbra (V > 0.01)";
    // The side edge widens away from the foot (contact hardening).
    const double nearFoot = test::sideEdgeWidth(*frame, v, 0.6f), farFromFoot = test::sideEdgeWidth(*frame, v, 2.0f);
    EXPECT_LT(nearFoot, 0.85 * farFromFoot) << "near the foot " << nearFoot << ", far " << farFromFoot;
}

TEST_F(VssmTest, LargestMapAgreesWithTheRays)
{
    // 4096^2 (the SAT's entries reach 2^55 here): the same agreement as at 1024^2.
    VssmSettings s;
    s.resolution = 4096;
    s.lightSize = 0.6;
    const std::vector<float> v = renderWith(test::defaultTestConfig(), s);
    expectRayCastAgreement(v, s, "4096^2");
}

TEST_F(VssmTest, RectLightMapLargerThanOneStorageBufferAgreesWithTheRays)
{
    // A rect light's six faces at the first resolution (in steps of 512) whose min-max
    // hierarchy (a third of the atlas, 8 bytes a texel) is more than the device binds as
    // one storage buffer: lavapipe's 128 MiB, 3072^2 here. The hierarchy is an image
    // (hsm.glsl), so the map is not refused and gives what 1024^2 gives.
    const VkPhysicalDeviceLimits& limits = context->properties().limits;
    uint32_t resolution = 1024;
    while (6.0 * resolution * resolution / 3.0 * 8.0 <= double(limits.maxStorageBufferRange)) resolution += 512;
    const double satBytes = 6.0 * resolution * resolution * 16.0;
    if (3 * resolution > limits.maxImageDimension2D || satBytes > double(context->maxMemoryAllocationSize()))
        GTEST_SKIP() << "this device binds storage buffers as large as the largest atlas it can make";
    config::RenderConfig cfg = test::defaultTestConfig();
    test::setLightType(cfg.lights[0], scene::LightType::Rect);
    VssmSettings s;
    s.resolution = int(resolution);
    const std::vector<float> v = renderWith(cfg, s);
    expectRayCastAgreement(v, s, fmt::format("rect {}^2", resolution));
    size_t soft = 0;
    for (float x : v) soft += x > 0.02f && x < 0.98f;
    EXPECT_GT(soft, 200u) << "a light with a size casts penumbrae";
}

TEST_F(VssmTest, TableLargerThanTheLargestAllocationIsRefusedWithTheLargestResolutionThatFits)
{
    // A rect light's summed-area table takes 16 bytes a texel of its 3 x 2 atlas: the
    // first resolution whose table is more than the device allocates at once, while its
    // atlas is still an image the device can make (lavapipe: 2 GiB, 4736^2).
    const VkPhysicalDeviceLimits& limits = context->properties().limits;
    const VkDeviceSize largest = context->maxMemoryAllocationSize();
    uint32_t resolution = 1024;
    while (VkDeviceSize(6) * resolution * resolution * 16 <= largest) resolution += 128;
    if (3 * (resolution + 64) > limits.maxImageDimension2D)
        GTEST_SKIP() << "this device allocates a table as large as the largest atlas image it can make";
    config::RenderConfig cfg = test::defaultTestConfig();
    test::setLightType(cfg.lights[0], scene::LightType::Rect);
    VssmSettings s;
    s.resolution = int(resolution);
    applyVssm(cfg.lights[0], s);
    try {
        render(cfg, config::buildScene(cfg.scene));
        FAIL() << "a " << resolution << "^2 table was not refused";
    } catch (const Error& e) {  // the registry's PluginError, naming the plugin and the light
        const std::string what = e.what();
        EXPECT_NE(what.find("vssm: resolution"), std::string::npos) << what;
        EXPECT_NE(what.find("maxMemoryAllocationSize"), std::string::npos) << what;
        const size_t at = what.find("use at most ");
        ASSERT_NE(at, std::string::npos) << what;
        const unsigned long fits = std::stoul(what.substr(at + 12));
        EXPECT_LT(fits, resolution) << what;
        EXPECT_GT(fits, resolution - 256) << what << ": the largest that fits, not any that fits";
        EXPECT_LE(VkDeviceSize(6) * fits * fits * 16, largest) << what;
    }
}

namespace {

class VssmScales : public VssmTest, public ::testing::WithParamInterface<std::tuple<float, LightCase>> {};

} // namespace

TEST_P(VssmScales, MatchesRayCastAwayFromPenumbrae)
{
    // Depths are normalised to the light's depth range and the thresholds are relative to
    // the scene's radius, so nothing depends on absolute units.
    const auto& [scale, c] = GetParam();
    config::RenderConfig cfg = test::defaultTestConfig();
    test::setLightType(cfg.lights[0], c.type);
    VssmSettings s;
    s.lightSize = c.lightSize * scale;
    test::scaleConfig(cfg, scale);
    const std::vector<float> v = renderWith(cfg, s);
    expectRayCastAgreement(v, s, c.name);
}

INSTANTIATE_TEST_SUITE_P(Vssm, VssmScales,
                         ::testing::Combine(::testing::Values(1e-3f, 1e5f),
                                            ::testing::Values(LightCase{"spot", scene::LightType::Spot, 0.6},
                                                              LightCase{"point", scene::LightType::Point, 0.4},
                                                              LightCase{"disk", scene::LightType::Disk, 1.0})),
                         [](const ::testing::TestParamInfo<std::tuple<float, LightCase>>& info) {
                             return std::string(std::get<0>(info.param) < 1.0f ? "milli_" : "e5_") +
                                    std::get<1>(info.param).name;
                         });

// ---------------------------------------------------------------------------------
// Debug views.

TEST_F(VssmTest, DebugImagesShowKernelClassificationAndSubKernels)
{
    config::RenderConfig cfg = test::defaultTestConfig();
    VssmSettings s;
    s.lightSize = 0.6;
    applyVssm(cfg.lights[0], s);
    render(cfg, config::buildScene(cfg.scene),
           {"light0.vssm.kernel", "light0.vssm.classification", "light0.vssm.subkernels"});
    const std::vector<float> v = frame->checkedVisibility();
    const auto read = [&](const char* name) {
        const metrics::DebugImageValues image = frame->renderer.readImage(name);
        EXPECT_EQ(image.width, cfg.width);
        EXPECT_EQ(image.height, cfg.height);
        EXPECT_EQ(image.channels, 1u);
        return image.values;
    };
    const std::vector<float> classes = read("light0.vssm.classification");
    const std::vector<float> kernel = read("light0.vssm.kernel");
    const std::vector<float> visited = read("light0.vssm.subkernels");
    ASSERT_EQ(classes.size(), v.size());

    // Classification: every pixel with geometry is one of the five classes (stored as
    // floats: exactly), and the scene has lit, umbra and penumbra pixels; where V is 0 by
    // the HSM the class says so. Without geometry every image is 0.
    std::map<float, size_t> count;
    for (size_t i = 0; i < classes.size(); ++i) {
        if (!frame->hasGeometry(i)) {
            EXPECT_EQ(classes[i] + kernel[i] + visited[i], 0.0f) << "pixel " << i << " without geometry";
            continue;
        }
        const float c = classes[i];
        EXPECT_TRUE(c == 0.0f || c == 0.25f || c == 0.5f || c == 0.75f || c == 1.0f) << "pixel " << i << ": " << c;
        ++count[c];
        // V is weighted by the light above the receiver's horizon after the class.
        if (c == 0.0f) {
            EXPECT_EQ(v[i], 0.0f) << "umbra pixel " << i;
        }
    }
    EXPECT_GT(count[1.0f], classes.size() / 10) << "lit";
    EXPECT_GT(count[0.0f], 100u) << "umbra";
    EXPECT_GT(count[0.5f] + count[0.75f], 100u) << "penumbra";

    // Kernel: 0 where the HSM decided, in (0, 1] in penumbrae. Sub-kernels: none where
    // the HSM decided, some in every penumbra pixel, never more than the most possible.
    size_t withKernel = 0, penumbraVisited = 0;
    for (size_t i = 0; i < kernel.size(); ++i) {
        if (!frame->hasGeometry(i)) continue;
        EXPECT_TRUE(kernel[i] >= 0.0f && kernel[i] <= 1.0f) << "pixel " << i << ": " << kernel[i];
        EXPECT_TRUE(visited[i] >= 0.0f && visited[i] <= 1.0f) << "pixel " << i << ": " << visited[i];
        if (classes[i] == 0.0f) {
            EXPECT_EQ(kernel[i], 0.0f) << "pixel " << i;
            EXPECT_EQ(visited[i], 0.0f) << "pixel " << i;
        }
        withKernel += kernel[i] > 0.0f;
        if (classes[i] == 0.5f || classes[i] == 0.75f) penumbraVisited += visited[i] > 0.0f;
    }
    EXPECT_GT(withKernel, 100u);
    EXPECT_EQ(penumbraVisited, count[0.5f] + count[0.75f]);

    // The visibility is the same as without the debug pass.
    render(cfg, config::buildScene(cfg.scene));
    EXPECT_EQ(frame->checkedVisibility(), v);
}

TEST_F(VssmTest, DebugViewsPassRunsOnlyWhenOneOfItsImagesIsRequested)
{
    config::RenderConfig cfg = test::defaultTestConfig();
    cfg.width = 64;
    cfg.height = 48;
    const VssmSettings defaults;
    applyVssm(cfg.lights[0], defaults);
    const auto runs = [&](const graph::CompiledGraph& compiled, const std::string& name) {
        return std::ranges::any_of(compiled.passes, [&](const graph::CompiledPass& p) { return p.name == name; });
    };
    render(cfg, config::buildScene(cfg.scene));
    const std::vector<std::string> names = frame->renderer.imageNames();
    for (const char* image : {"light0.vssm.kernel", "light0.vssm.classification", "light0.vssm.subkernels"})
        EXPECT_NE(std::ranges::find(names, image), names.end()) << image << " can be requested";
    EXPECT_FALSE(runs(frame->renderer.compiledGraph(), "light0.vssm.debug_views")) << "culled: nobody reads it";
    render(cfg, config::buildScene(cfg.scene), {"light0.vssm.subkernels"});
    EXPECT_TRUE(runs(frame->renderer.compiledGraph(), "light0.vssm.debug_views"));
}

// ---------------------------------------------------------------------------------
// Parameters.

TEST(VssmPluginEntry, ReflectsEveryParameterWithItsDefault)
{
    plugin::PluginRegistry registry;
    const plugin::ParamValues params = registry.load("vssm").defaultParams();
    EXPECT_EQ(params.getInt("resolution"), 1024);
    EXPECT_EQ(params.getEnum("subdivision"), "mixed");
    EXPECT_EQ(params.getInt("blocker_subdivisions"), 5);  // the paper's m
    EXPECT_EQ(params.getInt("tree_height"), 3);           // and H (6.2)
    EXPECT_FLOAT_EQ(params.getFloat("lit_variance"), 1e-4f);
    EXPECT_FLOAT_EQ(params.getFloat("contact_epsilon"), 0.01f);
    EXPECT_EQ(params.getFloat("max_search_radius"), 0.0625f);  // of the face's side
    EXPECT_EQ(params.getFloat("max_filter_radius"), 0.0625f);
    // The debug views are debug images (light0.vssm.kernel, ...), not a parameter.
    EXPECT_TRUE(std::ranges::none_of(params.specs(), [](const plugin::ParamSpec& spec) { return spec.name == std::string("debug_view"); }));
    for (const plugin::ParamSpec& spec : params.specs()) EXPECT_NE(std::string(spec.doc), "") << spec.name;
}

TEST(VssmPluginEntry, OutOfRangeValuesNameTheParameter)
{
    test::expectRefusalsNameTheParameter("vssm", {{"resolution", 16384},
                                                  {"tree_height", 6},
                                                  {"blocker_subdivisions", 0},
                                                  {"subdivision", "quadtree"},
                                                  {"lit_variance", -1.0},
                                                  {"max_filter_radius", 0.0}});
}
