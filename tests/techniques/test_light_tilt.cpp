// Every technique under a square area light tilted away from its occluder's normal: the
// penumbra scene's 1 x 1 plate at h = 1 (scene/Generators.h generatePenumbra, a thin
// double-sided quad) lit by a square rect light 2 m from the plate's centre, along a
// direction tilted 0°, 30°, 60° and 80° from the plate's normal and facing the plate.
// The exact visibility of a ground point p is the share of the light polygon outside the
// occluder's pyramid (the planes through p and each edge of the plate, beyond the plate's
// plane), computed here by clipping the light polygon with those five planes. Where the
// exact answer is umbra, with margin (a light 1.5 times as wide, same centre, is still
// hidden), every technique must be dark: V <= 0.1, except where its README documents
// otherwise (TiltCase::documentedFromTilt). The reference must match the exact answer.
#include "ExactVisibility.h"
#include "PluginFrame.h"
#include "TestConfigs.h"

#include "penumbra/scene/Generators.h"

#include <gtest/gtest.h>

#include <glm/glm.hpp>

#include <array>
#include <cmath>
#include <iomanip>
#include <ostream>
#include <sstream>
#include <string>
#include <vector>

using namespace penumbra;

namespace {

constexpr float kPlateHeight = 1.0f;
constexpr float kLightDistance = 2.0f;  // from the plate's centre
constexpr float kLightSide = 0.5f;
constexpr float kUmbraDark = 0.1f;

using test::Polygon;

struct TiltedLight {
    glm::dvec3 centre, normal, tangent, bitangent;  // normal: the emitting side (towards the plate)
    glm::dvec2 sides;                               // along the tangent, the bitangent

    Polygon corners(double scale = 1.0) const
    {
        const glm::dvec3 s = 0.5 * sides.x * scale * tangent, t = 0.5 * sides.y * scale * bitangent;
        return {centre - s - t, centre + s - t, centre + s + t, centre - s + t};
    }
};

TiltedLight tiltedLight(double tiltDeg, glm::dvec2 sides = glm::dvec2(kLightSide), double distance = kLightDistance)
{
    const double a = glm::radians(tiltDeg);
    const glm::dvec3 towards(std::sin(a), std::cos(a), 0.0);
    TiltedLight l;
    l.centre = glm::dvec3(0.0, kPlateHeight, 0.0) + distance * towards;
    l.normal = -towards;
    l.tangent = {0.0, 0.0, 1.0};
    l.bitangent = glm::cross(l.normal, l.tangent);
    l.sides = sides;
    return l;
}

// The share of the light (its polygon scaled by `scale` about its centre) that the plate
// hides from ground point p.
double hiddenShare(const TiltedLight& light, const glm::dvec3& p, double scale = 1.0)
{
    const double s = 0.5;  // the plate's half side
    const Polygon plate{glm::dvec3(-s, kPlateHeight, -s), glm::dvec3(s, kPlateHeight, -s), glm::dvec3(s, kPlateHeight, s),
                        glm::dvec3(-s, kPlateHeight, s)};
    return test::hiddenShare(light.corners(scale), plate, p);
}

// The ground the plate's shadow falls on: the plate's corners projected from the light's
// centre, as x range (the tilt is about z).
std::pair<double, double> shadowXRange(const TiltedLight& light)
{
    double lo = 1e30, hi = -1e30;
    for (double x : {-0.5, 0.5}) {
        const glm::dvec3 corner(x, kPlateHeight, 0.0);
        const double t = light.centre.y / (light.centre.y - corner.y);  // centre + t (corner - centre) on y = 0
        const double ground = light.centre.x + t * (corner.x - light.centre.x);
        lo = std::min(lo, ground);
        hi = std::max(hi, ground);
    }
    return {lo, hi};
}

// The camera looks straight down on the shadow with a 100° vertical field of view (x
// spans 1.9 times the height either way at 16:9): from below the plate (0.9 m) while the
// plate would be in view, higher where the shadow is long and far from it.
config::RenderConfig tiltConfig(const TiltedLight& l)
{
    const auto [lo, hi] = shadowXRange(l);
    const double middle = 0.5 * (lo + hi), halfWidthPerHeight = std::tan(glm::radians(50.0)) * 16.0 / 9.0;
    double height = 0.9;
    const double needed = 0.55 * (hi - lo) / halfWidthPerHeight;
    if (needed > height && middle + needed * halfWidthPerHeight < -0.5) height = needed;
    config::RenderConfig cfg =
        test::lookDownRectLightConfig({float(middle), float(height), 0.0f}, glm::vec3(l.centre), kLightSide);
    cfg.camera.fovYDeg = 100.0f;
    cfg.scene = {};
    scene::Light& light = cfg.lights[0].light;
    light.direction = glm::vec3(l.normal);
    light.tangent = glm::vec3(l.tangent);
    light.sizeWorld = glm::vec2(l.sides);
    return cfg;
}

struct TiltCase {
    const char* name;
    const char* technique;
    nlohmann::json params;
    // From this tilt on, the deep umbra may be as bright as `documentedMax` (the
    // technique's README says why); 0: never.
    double documentedFromTilt = 0.0;
    float documentedMax = kUmbraDark;
};

void PrintTo(const TiltCase& c, std::ostream* os) { *os << c.name; }

// Renders the plate under `light` with `technique`; V of the light.
class TiltTest : public test::PluginGpuTest {
protected:
    std::vector<float> renderUnder(const TiltedLight& light, const char* technique, const nlohmann::json& params,
                                   uint32_t width = 0, uint32_t height = 0)
    {
        config::RenderConfig cfg = tiltConfig(light);
        if (width > 0) {
            cfg.width = width;
            cfg.height = height;
        }
        test::setShadow(cfg.lights[0], technique, params);
        scene::PenumbraParams plate;
        plate.occluderHeight = kPlateHeight;
        plate.occluderThickness = 0.0f;
        render(cfg, scene::generatePenumbra(plate));
        return frame->checkedVisibility();
    }
};

class LightTilt : public TiltTest, public ::testing::WithParamInterface<TiltCase> {};

} // namespace

TEST_P(LightTilt, DeepUmbraIsDark)
{
    const TiltCase& c = GetParam();
    for (double tilt : {0.0, 30.0, 60.0, 80.0}) {
        SCOPED_TRACE(testing::Message() << c.name << ", light tilted " << tilt << "°");
        const TiltedLight light = tiltedLight(tilt);
        const std::vector<float> v = renderUnder(light, c.technique, c.params);
        size_t umbra = 0, bright = 0;
        double sum = 0.0, worst = 0.0, squared = 0.0;
        size_t ground = 0;
        for (size_t i = 0; i < v.size(); ++i) {
            if (!frame->onGround(i)) continue;
            const glm::dvec3 p(frame->position(i));
            const double exact = 1.0 - hiddenShare(light, p);
            squared += (v[i] - exact) * (v[i] - exact);
            ++ground;
            if (hiddenShare(light, p, 1.5) < 1.0 - 1e-9) continue;  // not deep umbra
            ++umbra;
            sum += v[i];
            worst = std::max(worst, double(v[i]));
            bright += v[i] > kUmbraDark;
        }
        std::cout << c.name << " tilt " << tilt << ": deep umbra " << umbra << " px, mean V " << std::fixed
                  << std::setprecision(3) << sum / std::max<size_t>(umbra, 1) << ", max " << worst << ", > "
                  << kUmbraDark << ": " << bright << "; RMSE over the ground "
                  << std::sqrt(squared / std::max<size_t>(ground, 1)) << "\n";
        // At 80° the light's centre lies almost in the plate's plane and no ground point
        // is deep umbra.
        if (tilt < 70.0) {
            EXPECT_GT(umbra, 300u) << "the camera sees the deep umbra";
        }
        const bool documented = c.documentedFromTilt > 0.0 && tilt >= c.documentedFromTilt;
        if (documented) {
            EXPECT_LE(worst, c.documentedMax) << "the README's bound on the deep umbra";
        } else {
            EXPECT_EQ(bright, 0u) << "deep-umbra pixels with V > " << kUmbraDark << " (mean "
                                  << sum / std::max<size_t>(umbra, 1) << ", max " << worst << ")";
        }
        // The ground truth is the truth: rays against the exact answer, every pixel.
        if (std::string(c.technique) == "reference") {
            EXPECT_LT(std::sqrt(squared / std::max<size_t>(ground, 1)), 0.01) << "the reference's RMSE";
        }
    }
}

INSTANTIATE_TEST_SUITE_P(
    Techniques, LightTilt,
    ::testing::Values(TiltCase{"hard", "hard", nlohmann::json::object()},
                      TiltCase{"pcss", "pcss", nlohmann::json::object()},
                      TiltCase{"vsm", "vsm", nlohmann::json::object()},
                      // plugins/vssm/README.md: `none` lights a non-planar search kernel
                      // (SAVSM's incorrectly-lit case, the paper's baseline).
                      TiltCase{"vssm_none", "vssm", {{"subdivision", "none"}}, 60.0, 1.0f},
                      TiltCase{"vssm_uniform", "vssm", {{"subdivision", "uniform"}}},
                      TiltCase{"vssm_adaptive", "vssm", {{"subdivision", "adaptive"}}},
                      TiltCase{"vssm_mixed", "vssm", {{"subdivision", "mixed"}}},
                      TiltCase{"reference", "reference", nlohmann::json::object()}),
    [](const ::testing::TestParamInfo<TiltCase>& info) { return std::string(info.param.name); });

namespace {

// A wide light at grazing tilts: a 1.2 x 0.8 rect light 2.7 m from the plate's centre
// (its long side along the tilt axis), the case where a kernel capped to a fixed width
// leaves a seam or bands. Every soft technique's RMSE against the exact visibility over
// the ground stays within its bound at every tilt from 0° to 85°: the worst of the tilts
// as measured (320 x 180, each technique's defaults; the README's figure) with 10 %
// margin.
struct WideLightCase {
    const char* name;
    const char* technique;
    nlohmann::json params;
    double rmseBound;
    double oblongBound = 0.0;  // untilted (AnOblongLightsSidesEachGiveTheirOwnPenumbra); 0: rmseBound
};

void PrintTo(const WideLightCase& c, std::ostream* os) { *os << c.name; }

// V against the exact visibility over the ground in view.
struct GroundError {
    double rmse = 0.0, worst = 0.0;
    size_t ground = 0, off = 0;  // ground pixels, and those off by more than 0.2
};

class WideLightTilt : public TiltTest, public ::testing::WithParamInterface<WideLightCase> {
protected:
    GroundError groundError(const TiltedLight& light, const std::vector<float>& v) const
    {
        GroundError e;
        double squared = 0.0;
        for (size_t i = 0; i < v.size(); ++i) {
            if (!frame->onGround(i)) continue;
            const double error = v[i] - (1.0 - hiddenShare(light, glm::dvec3(frame->position(i))));
            squared += error * error;
            e.worst = std::max(e.worst, std::abs(error));
            e.off += std::abs(error) > 0.2;
            ++e.ground;
        }
        e.rmse = e.ground > 0 ? std::sqrt(squared / double(e.ground)) : 0.0;
        return e;
    }
};

} // namespace

// The same 1.2 x 0.8 light, untilted: its penumbra is 1.5 times as wide along the long
// side as along the short one, which one isotropic light size cannot give. PCSS and VSSM
// are held to their measured RMSE with 10 % margin (pcss 0.021, vssm 0.0018; with one
// isotropic size they were 0.032 and 0.026: common/penumbra_estimate.glsl
// shadowLightExtent), the others to their bound at every tilt.
TEST_P(WideLightTilt, AnOblongLightsSidesEachGiveTheirOwnPenumbra)
{
    const WideLightCase& c = GetParam();
    const double bound = c.oblongBound > 0.0 ? c.oblongBound : c.rmseBound;
    const TiltedLight light = tiltedLight(0.0, {1.2, 0.8}, 2.7);
    const GroundError e = groundError(light, renderUnder(light, c.technique, c.params, 320, 180));
    ASSERT_GT(e.ground, 1000u) << "the camera sees the ground";
    EXPECT_LE(e.rmse, bound);
}

TEST_P(WideLightTilt, PenumbraFollowsTheExactAnswer)
{
    const WideLightCase& c = GetParam();
    for (double tilt : {0.0, 40.0, 60.0, 70.0, 80.0, 85.0}) {
        SCOPED_TRACE(testing::Message() << c.name << ", light tilted " << tilt << "°");
        const TiltedLight light = tiltedLight(tilt, {1.2, 0.8}, 2.7);
        const GroundError e = groundError(light, renderUnder(light, c.technique, c.params, 320, 180));
        ASSERT_GT(e.ground, 1000u) << "the camera sees the ground";
        std::cout << c.name << " tilt " << tilt << ": RMSE " << std::fixed << std::setprecision(4) << e.rmse
                  << ", worst " << e.worst << ", off by > 0.2: " << 100.0 * double(e.off) / double(e.ground) << " %\n";
        EXPECT_LE(e.rmse, c.rmseBound);
    }
}

INSTANTIATE_TEST_SUITE_P(
    Techniques, WideLightTilt,
    ::testing::Values(WideLightCase{"pcss", "pcss", nlohmann::json::object(), 0.100, 0.023},
                      WideLightCase{"vssm", "vssm", nlohmann::json::object(), 0.216, 0.002},
                      WideLightCase{"backprojection", "backprojection", nlohmann::json::object(), 0.0092},
                      WideLightCase{"reference", "reference", nlohmann::json::object(), 0.0055}),
    [](const ::testing::TestParamInfo<WideLightCase>& info) { return std::string(info.param.name); });
