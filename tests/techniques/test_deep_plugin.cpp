// The deep shadow map plugin (plugins/deep) end to end: translucent panes against the
// closed form 0.7^n, an opaque scene against the hard plugin, the linked lookup against
// the brute-force one, truncation within its epsilon, a faint fragment in front of an
// opaque one, a pool too small for the frame, and parameter errors.
#include "PluginFrame.h"
#include "TestConfigs.h"
#include "TestContext.h"
#include "TestPaths.h"
#include "ScratchFolder.h"

#include "penumbra/config/Config.h"
#include "penumbra/core/Error.h"
#include "penumbra/metrics/DebugImage.h"
#include "penumbra/metrics/ImageComparison.h"
#include "penumbra/scene/GltfWriter.h"
#include "penumbra/scene/Generators.h"

#include <gtest/gtest.h>

#include <fmt/format.h>
#include <glm/gtc/constants.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <filesystem>
#include <functional>
#include <iostream>
#include <map>
#include <cmath>
#include <string>
#include <vector>

using namespace penumbra;
namespace fs = std::filesystem;

namespace {

class DeepPlugin : public test::PluginGpuTest {
protected:
    bool hasPass(const std::string& name)
    {
        for (const graph::CompiledPass& p : frame->renderer.compiledGraph().passes)
            if (p.name == name) return true;
        return false;
    }
    std::vector<float> renderDeep(config::RenderConfig cfg, scene::Scene scene, const nlohmann::json& params)
    {
        test::setShadow(cfg.lights[0], "deep", params);
        render(cfg, std::move(scene));
        return frame->checkedVisibility();
    }
};

float maxDifference(const std::vector<float>& a, const std::vector<float>& b)
{
    float worst = 0.0f;
    for (size_t i = 0; i < a.size(); ++i) worst = std::max(worst, std::abs(a[i] - b[i]));
    return worst;
}

// The figure `name` of light 0's technique in the last frame; fails when it is missing.
double figure(const test::RenderedFrame& f, const std::string& name)
{
    if (!f.timings.techniques.empty())
        for (const plugin::TechniqueFigure& figure : f.timings.techniques[0])
            if (figure.name == name) return figure.value;
    ADD_FAILURE() << "no figure " << name;
    return 0.0;
}

// A camera looking down on the ground beside the panes, and a light of `type` up and to
// the side, so that the panes' shadows fall on the ground in view.
config::RenderConfig panesConfig(scene::LightType type, float scale = 1.0f)
{
    config::RenderConfig cfg = test::defaultTestConfig();
    cfg.width = 96;
    cfg.height = 72;
    cfg.camera.position = {-2.0f, 7.0f, 0.001f};
    cfg.camera.target = {-2.0f, 0.0f, 0.0f};
    cfg.camera.up = {0.0f, 0.0f, -1.0f};
    cfg.camera.fovYDeg = 40.0f;
    cfg.camera.nearWorld = 0.05f;
    cfg.lights.resize(1);
    scene::Light& light = cfg.lights[0].light;
    light = scene::Light{};
    light.type = type;
    light.position = {3.0f, 4.0f, 0.0f};
    const glm::vec3 towardsShadow = glm::normalize(glm::vec3(-2.0f, 0.0f, 0.0f) - light.position);
    light.direction = towardsShadow;
    light.outerConeDeg = 50.0f;
    light.innerConeDeg = 45.0f;
    light.intensity = type == scene::LightType::Directional ? 3.0f : 40.0f;
    cfg.camera.position *= scale;
    cfg.camera.target *= scale;
    cfg.camera.nearWorld *= scale;
    light.position *= scale;
    light.intensity *= type == scene::LightType::Directional ? 1.0f : scale * scale;
    return cfg;
}

// The panes a ground point's ray to the light crosses, or -1 within `band` (world units)
// of a pane's edge: a texel straddles it there, and the normal offset moves the lookup
// by a few texels on a ground lit at 60 degrees.
int panesCrossed(const scene::Light& light, const glm::vec3& p, const std::vector<float>& heights, double band,
                 float scale = 1.0f)
{
    int crossed = 0;
    for (float h : heights) {
        // The ray p + t d reaches height h at t = h / d.y (p, the panes and the light's
        // position in the scene's units divided by `scale`).
        const glm::dvec3 d = light.type == scene::LightType::Directional
                                 ? -glm::dvec3(light.direction)
                                 : glm::dvec3(light.position) / double(scale) - glm::dvec3(p);
        const glm::dvec3 at = glm::dvec3(p) + d * ((double(h) - p.y) / d.y);
        const double inside = 1.0 - std::max(std::abs(at.x), std::abs(at.z));
        if (std::abs(inside) < band) return -1;
        crossed += inside > 0.0 ? 1 : 0;
    }
    return crossed;
}

// Behind n panes of alpha 0.3 the light is 0.7^n (the reference's closed form), for one,
// two and five panes, through a spot light's map, a directional light's and a point
// light's cube faces, and for the spot light with the whole scene at 1e-3 and 1e5 the
// size (depths, offsets and bounds all relative to the scene).
TEST_F(DeepPlugin, TranslucentPanesAttenuateByOneMinusAlphaEach)
{
    const std::vector<std::vector<float>> stacks = {{1.0f}, {1.0f, 1.5f}, {1.0f, 1.25f, 1.5f, 1.75f, 2.0f}};
    struct Case {
        scene::LightType type;
        float scale;
    };
    const Case cases[] = {{scene::LightType::Spot, 1.0f},        {scene::LightType::Directional, 1.0f},
                          {scene::LightType::Point, 1.0f},       {scene::LightType::Spot, 1e-3f},
                          {scene::LightType::Spot, 1e5f},        {scene::LightType::Point, 1e5f}};
    for (const Case& c : cases) {
        for (const std::vector<float>& heights : stacks) {
            SCOPED_TRACE(fmt::format("{} light, scale {}, {} pane(s)", scene::lightTypeName(c.type), c.scale,
                                     heights.size()));
            const config::RenderConfig cfg = panesConfig(c.type, c.scale);
            const std::vector<float> v = renderDeep(cfg, test::panesScene(heights, 0.3f, {}, c.scale), {{"resolution", 512}});
            std::vector<size_t> counted(heights.size() + 1, 0);
            for (size_t i = 0; i < v.size(); ++i) {
                if (!frame->hasGeometry(i) || std::abs(frame->position(i).y) > 1e-4f * c.scale) continue;
                const int crossed =
                    panesCrossed(cfg.lights[0].light, frame->position(i) / c.scale, heights, 0.15, c.scale);
                if (crossed < 0) continue;
                const glm::vec3 q = frame->position(i);
                ASSERT_NEAR(v[i], std::pow(0.7, crossed), 1e-4) << "pixel " << i << ", " << crossed << " pane(s) at " << q.x << " " << q.y << " " << q.z;
                ++counted[size_t(crossed)];
            }
            EXPECT_GT(counted.front(), 30u) << "lit pixels";
            EXPECT_GT(counted.back(), 30u) << "pixels behind every pane";
        }
    }
}

// Without translucent casters every list ends at its first node (transmittance 0), and
// the lookup is the hard plugin's compare: the same image as `hard` with the same
// receiver bias (normal offset, no rasterizer bias), bit for bit, with and without PCF,
// through one face and through the cube atlas (its guard band too).
TEST_F(DeepPlugin, OpaqueSceneGivesTheHardPluginsImage)
{
    for (const scene::LightType type : {scene::LightType::Spot, scene::LightType::Directional, scene::LightType::Point}) {
        for (const int kernel : {1, 3}) {
            SCOPED_TRACE(fmt::format("{} light, {} x {} taps", scene::lightTypeName(type), kernel, kernel));
            config::RenderConfig cfg = test::defaultTestConfig();
            cfg.width = 160;
            cfg.height = 90;
            test::setLightType(cfg.lights[0], type);
            test::setShadow(cfg.lights[0], "hard",
                            {{"resolution", 512}, {"bias_mode", "normal_offset"}, {"depth_bias", 0}, {"slope_bias", 0},
                             {"filter", kernel > 1 ? "pcf" : "none"}, {"pcf_kernel", kernel}, {"normal_offset", 1.0}});
            render(cfg, config::buildScene(cfg.scene));
            const std::vector<float> hard = frame->checkedVisibility();
            const std::vector<float> deep = renderDeep(cfg, config::buildScene(cfg.scene),
                                                       {{"resolution", 512}, {"pcf_kernel", kernel},
                                                        {"bias_mode", "normal_offset"}});
            size_t shadowed = 0;
            for (float v : hard) shadowed += v < 0.5f ? 1 : 0;
            EXPECT_GT(shadowed, 200u);
            EXPECT_EQ(maxDifference(hard, deep), 0.0f);
            // Each list's first node alone (Table 1.1's "SM") is the same binary map here.
            const std::vector<float> first =
                renderDeep(cfg, config::buildScene(cfg.scene),
                           {{"resolution", 512}, {"pcf_kernel", kernel}, {"bias_mode", "normal_offset"},
                            {"filter", "first_fragment"}});
            EXPECT_EQ(maxDifference(deep, first), 0.0f);
            // Behind the opaque casters' depth nothing is stored: one fragment a texel, but
            // where two surfaces lie at exactly its depth (a box's foot on the ground), and
            // the sort keeps one node of those.
            const double fragments = figure(*frame, "fragments"), kept = figure(*frame, "nodes_kept");
            EXPECT_LE(figure(*frame, "longest_list"), 2.0);
            EXPECT_LE(fragments - kept, 1e-4 * fragments);
            EXPECT_GT(kept, 1e4);

            // Slope-scaled bias (both plugins' default): the rasterizer's formula applied in
            // the fragment shader, so the same shadows but for pixels whose taps sit on the
            // edge of the bias, where the shader's slope (a difference of two rounded
            // depths) and the rasterizer's differ in the last bits: measured 0.01-0.02% of
            // the pixels with one tap, 0.1-0.4% with PCF 3 x 3 (slope_bias scaled by 3).
            test::setShadow(cfg.lights[0], "hard",
                            {{"resolution", 512}, {"filter", kernel > 1 ? "pcf" : "none"}, {"pcf_kernel", kernel}});
            render(cfg, config::buildScene(cfg.scene));
            const std::vector<float> hardSlope = frame->checkedVisibility();
            const std::vector<float> deepSlope =
                renderDeep(cfg, config::buildScene(cfg.scene), {{"resolution", 512}, {"pcf_kernel", kernel}});
            size_t differ = 0;
            for (size_t i = 0; i < hardSlope.size(); ++i) differ += std::abs(hardSlope[i] - deepSlope[i]) > 1e-4f ? 1 : 0;
            EXPECT_LE(differ, hardSlope.size() / (kernel > 1 ? 100 : 1000));
        }
    }
}

// A small hair model (2,000 strands) under a spot light and a point light (links stop
// at the cube faces' edges).
config::RenderConfig hairConfig(scene::LightType type)
{
    config::RenderConfig cfg = config::loadConfig(test::sourceDir() / "config/hair.json");
    cfg.width = 120;
    cfg.height = 90;
    cfg.scene.parts[0].params = {{"strands", "2000"}};
    if (type == scene::LightType::Point) cfg.lights[0].light.type = type;
    return cfg;
}

// The links only choose where each tap's walk starts: every tap ends at the same node as
// a search from its list's head, so the images are equal bit for bit.
TEST_F(DeepPlugin, LinkedLookupGivesTheBruteForceImage)
{
    for (const scene::LightType type : {scene::LightType::Spot, scene::LightType::Point}) {
        const config::RenderConfig cfg = hairConfig(type);
        for (const int kernel : {3, 5, 7}) {
            SCOPED_TRACE(fmt::format("{} light, {} x {} taps", scene::lightTypeName(type), kernel, kernel));
            const nlohmann::json params = {{"resolution", 256}, {"pcf_kernel", kernel}};
            nlohmann::json brute = params;
            brute["lookup"] = "brute_force";
            const std::vector<float> linked = renderDeep(cfg, config::buildScene(cfg.scene), params);
            EXPECT_TRUE(hasPass("light0.deep.links"));
            const std::vector<float> searched = renderDeep(cfg, config::buildScene(cfg.scene), brute);
            EXPECT_FALSE(hasPass("light0.deep.links")) << "nothing follows the links";
            size_t fractional = 0;
            for (float v : linked) fractional += v > 0.01f && v < 0.99f ? 1 : 0;
            EXPECT_GT(fractional, 500u);
            EXPECT_EQ(maxDifference(linked, searched), 0.0f);
        }
    }
}

// Truncation at epsilon: behind n panes of alpha 0.3 the list ends at the first node k
// with 0.7^k <= epsilon, so V = 0.7^min(n, k), within epsilon of 0.7^n. On the hair no
// pixel moves by more than epsilon (plus V's 16-bit rounding).
TEST_F(DeepPlugin, TruncationErrorStaysWithinEpsilon)
{
    const std::vector<float> heights = {1.0f, 1.25f, 1.5f, 1.75f, 2.0f};
    const config::RenderConfig panes = panesConfig(scene::LightType::Spot);
    for (const double epsilon : {0.0, 0.2, 0.3, 0.45}) {
        SCOPED_TRACE(fmt::format("panes, epsilon {}", epsilon));
        const std::vector<float> v =
            renderDeep(panes, test::panesScene(heights, 0.3f), {{"resolution", 512}, {"epsilon", epsilon}});
        int k = 1;
        while (std::pow(0.7, k) > epsilon && k < 5) ++k;
        size_t behindAll = 0;
        for (size_t i = 0; i < v.size(); ++i) {
            if (!frame->onGround(i)) continue;
            const int crossed = panesCrossed(panes.lights[0].light, frame->position(i), heights, 0.15);
            if (crossed < 0) continue;
            ASSERT_NEAR(v[i], std::pow(0.7, std::min(crossed, k)), 1e-4) << "pixel " << i << ", " << crossed;
            ASSERT_LE(std::abs(v[i] - std::pow(0.7, crossed)), epsilon + 1e-4) << "pixel " << i;
            behindAll += crossed == 5 ? 1 : 0;
        }
        EXPECT_GT(behindAll, 30u);
    }
    const config::RenderConfig hair = hairConfig(scene::LightType::Spot);
    const std::vector<float> exact = renderDeep(hair, config::buildScene(hair.scene), {{"resolution", 256}, {"epsilon", 0}});
    for (const double epsilon : {0.001, 0.01, 0.1}) {
        SCOPED_TRACE(fmt::format("hair, epsilon {}", epsilon));
        const std::vector<float> cut =
            renderDeep(hair, config::buildScene(hair.scene), {{"resolution", 256}, {"epsilon", epsilon}});
        EXPECT_LE(maxDifference(exact, cut), epsilon + 2e-5);
    }
}

// A faint translucent layer (alpha 0.005) over an opaque plate, cut at epsilon 0.01: the
// paper's rule (stop where one more node changes the product by less than epsilon) would
// stop after the faint layer and light the ground under the plate (V = 0.995); the bound
// on the remaining transmittance keeps the plate.
TEST_F(DeepPlugin, AFaintLayerDoesNotHideAnOpaqueCasterBehindIt)
{
    const config::RenderConfig cfg = panesConfig(scene::LightType::Spot);
    const std::vector<float> v =
        renderDeep(cfg, test::panesScene({2.0f}, 0.005f, {1.0f}), {{"resolution", 512}, {"epsilon", 0.01}});
    size_t under = 0;
    for (size_t i = 0; i < v.size(); ++i) {
        if (!frame->onGround(i) || panesCrossed(cfg.lights[0].light, frame->position(i), {1.0f}, 0.15) != 1) continue;
        ASSERT_EQ(v[i], 0.0f) << "pixel " << i;
        ++under;
    }
    EXPECT_GT(under, 30u);
}

// A pool too small for the hair (1 MiB: 43,690 fragments) grows: the frame is drawn
// again with a pool that holds every fragment, and equals the frame of a pool large
// enough from the start. Capped at 1 MiB, the fragments past it are dropped and counted:
// the frame still renders, V stays within the contract, and the hair's shadow is lighter.
TEST_F(DeepPlugin, APoolTooSmallGrowsOrDropsAndCountsFragments)
{
    const config::RenderConfig cfg = hairConfig(scene::LightType::Spot);
    const std::vector<float> full = renderDeep(cfg, config::buildScene(cfg.scene), {{"resolution", 512}});
    EXPECT_EQ(frame->timings.redraws, 0u);
    const double fragments = figure(*frame, "fragments");
    EXPECT_GT(fragments, 43690.0 * 2);
    EXPECT_EQ(figure(*frame, "dropped_fragments"), 0.0);
    EXPECT_NEAR(figure(*frame, "pool_used_mib"), fragments * 24.0 / (1 << 20), 1e-6);
    double histogram = 0.0;
    for (const plugin::TechniqueFigure& f : frame->timings.techniques[0])
        if (f.name.starts_with("texels_with_")) histogram += f.value;
    EXPECT_GT(histogram, 1000.0);

    const std::vector<float> grown = renderDeep(cfg, config::buildScene(cfg.scene), {{"resolution", 512}, {"pool_mib", 1}});
    EXPECT_EQ(frame->timings.redraws, 1u);
    EXPECT_EQ(figure(*frame, "dropped_fragments"), 0.0);
    EXPECT_GE(figure(*frame, "pool_mib"), fragments * 24.0 / (1 << 20));
    EXPECT_EQ(maxDifference(full, grown), 0.0f);

    const std::vector<float> starved =
        renderDeep(cfg, config::buildScene(cfg.scene), {{"resolution", 512}, {"pool_mib", 1}, {"max_pool_mib", 1}});
    EXPECT_EQ(frame->timings.redraws, 0u);
    EXPECT_EQ(figure(*frame, "dropped_fragments"), fragments - 43690.0);
    double sumFull = 0.0, sumStarved = 0.0;
    for (size_t i = 0; i < full.size(); ++i) sumFull += full[i], sumStarved += starved[i];
    EXPECT_GT(sumStarved, sumFull + 10.0);
}

// The debug images agree with the figures and with each other: the depth complexity sums
// to the fragments appended, no list keeps more than reached it, every texel that a
// fragment reached keeps at least one, and the transmittance at the far plane is 0 under
// the ground (an opaque receiver that also casts) and 1 where no caster is.
TEST_F(DeepPlugin, DebugImagesCountTheListsAndReadThem)
{
    config::RenderConfig cfg = hairConfig(scene::LightType::Spot);
    test::setShadow(cfg.lights[0], "deep", {{"resolution", 256}, {"debug_depth", 1.0}});
    const std::vector<std::string> images = {"light0.deep.depth_complexity", "light0.deep.list_length",
                                             "light0.deep.transmittance"};
    render(cfg, config::buildScene(cfg.scene), images);
    const metrics::DebugImageValues complexity = frame->renderer.readImage(images[0]);
    const metrics::DebugImageValues length = frame->renderer.readImage(images[1]);
    const metrics::DebugImageValues transmittance = frame->renderer.readImage(images[2]);
    ASSERT_EQ(complexity.width, 256u);
    double fragments = 0.0;
    size_t empty = 0, opaque = 0;
    for (size_t i = 0; i < complexity.values.size(); ++i) {
        fragments += complexity.values[i];
        ASSERT_LE(length.values[i], complexity.values[i]) << i;
        ASSERT_EQ(length.values[i] > 0.0f, complexity.values[i] > 0.0f) << i;
        ASSERT_GE(transmittance.values[i], 0.0f);
        ASSERT_LE(transmittance.values[i], 1.0f);
        if (complexity.values[i] == 0.0f) {
            ++empty;
            ASSERT_EQ(transmittance.values[i], 1.0f) << i;
        }
        opaque += transmittance.values[i] == 0.0f ? 1 : 0;
    }
    EXPECT_EQ(fragments, figure(*frame, "fragments"));
    EXPECT_GT(opaque, 1000u);
    EXPECT_GT(empty, 1000u) << "texels beyond the ground";
    EXPECT_GT(figure(*frame, "longest_list"), 8.0);
}

// Against the ray-traced reference (which attenuates by 1 - alpha per crossing; spot
// lights without size: one exact sample), RMSE over the pixels with geometry, for DSM,
// DSM + PCF 3/5/7, EDSM and EDSM + PCF 3, and `hard` at the same resolution (translucent
// casters opaque): on two and five panes (also loaded from a glTF file written with
// BLEND materials), the hair (10,000 strands) and the opaque fence.
TEST_F(DeepPlugin, ErrorAgainstTheReference)
{
    struct Scene {
        const char* name;
        config::RenderConfig cfg;
        std::function<scene::Scene()> build;
    };
    const std::vector<float> two = {1.0f, 1.5f}, five = {1.0f, 1.25f, 1.5f, 1.75f, 2.0f};
    const fs::path scratch = test::makeScratchFolder("deep_panes");
    const fs::path gltf = scratch / "panes.gltf";
    scene::writeGltf(test::panesScene(five, 0.3f), gltf);
    config::RenderConfig fromFile = panesConfig(scene::LightType::Spot);
    fromFile.scene.parts[0].kind = config::ScenePart::Kind::Gltf;
    fromFile.scene.parts[0].gltf = gltf;
    config::RenderConfig hair = config::loadConfig(test::sourceDir() / "config/hair.json");
    hair.scene.parts[0].params = {{"strands", "10000"}};
    config::RenderConfig fence = config::loadConfig(test::sourceDir() / "config/fence.json");
    for (config::RenderConfig* c : {&hair, &fence}) c->width = 120, c->height = 90;
    std::vector<Scene> scenes = {
        {"2 panes", panesConfig(scene::LightType::Spot), [&] { return test::panesScene(two, 0.3f); }},
        {"5 panes", panesConfig(scene::LightType::Spot), [&] { return test::panesScene(five, 0.3f); }},
        {"5 panes (glTF)", fromFile, [&] { return config::buildScene(fromFile.scene); }},
        {"hair", hair, [&] { return config::buildScene(hair.scene); }},
        {"fence", fence, [&] { return config::buildScene(fence.scene); }},
    };
    struct Variant {
        const char* name;
        const char* technique;
        nlohmann::json params;
    };
    const std::vector<Variant> variants = {
        {"DSM", "deep", {}},
        {"DSM3", "deep", {{"pcf_kernel", 3}}},
        {"DSM5", "deep", {{"pcf_kernel", 5}}},
        {"DSM7", "deep", {{"pcf_kernel", 7}}},
        {"EDSM", "deep", {{"filter", "edsm"}}},
        {"EDSM3", "deep", {{"filter", "edsm"}, {"pcf_kernel", 3}}},
        {"hard", "hard", {}},
    };
    std::string table = "| scene | " ;
    for (const Variant& v : variants) table += std::string(v.name) + " | ";
    table += "\n";
    for (Scene& sc : scenes) {
        SCOPED_TRACE(sc.name);
        config::RenderConfig ref = sc.cfg;
        test::setShadow(ref.lights[0], "reference", {{"samples", 1}, {"cache", false}});
        render(ref, sc.build());
        const std::vector<float> reference = frame->checkedVisibility();
        const metrics::PixelMask mask = metrics::geometryMask(ref.width, ref.height, frame->positions);
        std::map<std::string, double> rmse;
        table += fmt::format("| {} | ", sc.name);
        for (const Variant& v : variants) {
            config::RenderConfig cfg = sc.cfg;
            nlohmann::json params = v.params;
            params["resolution"] = 1024;
            test::setShadow(cfg.lights[0], v.technique, params);
            render(cfg, sc.build());
            rmse[v.name] = metrics::compareVisibility({cfg.width, cfg.height, frame->checkedVisibility()},
                                                      {cfg.width, cfg.height, reference}, &mask)
                               .all.rmse;
            table += fmt::format("{:.4f} | ", rmse[v.name]);
        }
        table += "\n";
        if (std::string(sc.name).find("panes") != std::string::npos) {
            // Exact but for the panes' edges (a texel wide): measured 0.011 and 0.015.
            EXPECT_LT(rmse["DSM"], 0.03);
            EXPECT_GT(rmse["hard"], 0.15);
        } else if (std::string(sc.name) == "hair") {
            EXPECT_LT(rmse["DSM"], 0.8 * rmse["hard"]);
            EXPECT_LT(rmse["EDSM"], 0.8 * rmse["hard"]);
        } else {
            // Opaque: the lists hold hard's map, with the same slope-scaled bias.
            EXPECT_LT(rmse["DSM"], rmse["hard"] + 0.005);
        }
    }
    std::cout << table;
    fs::remove_all(scratch);
}

// Contact and grazing light. A translucent pane standing on the ground (x = 0, y in
// [0, 2], z in [-1, 1]) under a light to its side: the ground behind it gets 0.7 right up
// to its foot (here from 0.02 of the pane's height on): the bias (slope-scaled, on the
// stored depths) stays far below the gap between a ground point and the pane's fragment.
// The bare ground lit at 80 and 87 degrees from its normal shadows no pixel of itself
// (acne would give V near 0), with both bias modes.
TEST_F(DeepPlugin, ContactAndGrazingLight)
{
    scene::Scene standing = test::planeScene();
    standing.materials.push_back(
        {"glass", {1.0f, 1.0f, 1.0f, 0.3f}, scene::kNoTexture, scene::AlphaMode::Blend, 0.5f, true});
    scene::Mesh pane = scene::makePlane("pane");
    pane.material = uint32_t(standing.materials.size() - 1);
    test::addInstance(standing, test::addMesh(standing, pane), "pane", test::wallAt(0.0f));
    standing.updateTransforms();
    config::RenderConfig cfg = panesConfig(scene::LightType::Spot);
    cfg.camera.position = {0.6f, 3.0f, 0.001f};
    cfg.camera.target = {0.6f, 0.0f, 0.0f};
    scene::Light& light = cfg.lights[0].light;
    light.position = {-3.0f, 3.0f, 0.0f};
    light.direction = glm::normalize(glm::vec3(1.0f, 0.0f, 0.0f) - light.position);
    const std::vector<float> v = renderDeep(cfg, std::move(standing), {{"resolution", 1024}});
    size_t behind = 0;
    for (size_t i = 0; i < v.size(); ++i) {
        const glm::vec3 p = frame->position(i);
        // The ray to the light crosses x = 0 at height 3 x / (x + 3), at z (3 z) / (x + 3).
        const float z = 3.0f * p.z / (p.x + 3.0f);
        if (!frame->onGround(i) || p.x < 0.02f || p.x > 1.2f || std::abs(z) > 0.95f) continue;
        ASSERT_NEAR(v[i], 0.7f, 1e-4) << "pixel " << i << " at x " << p.x;
        ++behind;
    }
    EXPECT_GT(behind, 300u);

    for (const float degrees : {80.0f, 87.0f}) {
        for (const char* bias : {"slope", "normal_offset"}) {
            SCOPED_TRACE(fmt::format("{} degrees, {}", degrees, bias));
            config::RenderConfig grazing = panesConfig(scene::LightType::Directional);
            const float a = glm::radians(degrees);
            grazing.lights[0].light.direction = -glm::vec3(std::sin(a), std::cos(a), 0.0f);
            const std::vector<float> lit =
                renderDeep(grazing, test::planeScene(), {{"resolution", 1024}, {"bias_mode", bias}, {"pcf_kernel", 3}});
            size_t ground = 0;
            for (size_t i = 0; i < lit.size(); ++i) {
                if (!frame->onGround(i)) continue;
                ASSERT_GT(lit[i], 0.99f) << "pixel " << i;
                ++ground;
            }
            EXPECT_GT(ground, lit.size() / 2);
        }
    }
}

TEST_F(DeepPlugin, RefusesBadParametersByName)
{
    test::expectRefusalsNameTheParameter("deep", {{"pcf_kernel", 9}, {"pool_mib", 0}, {"max_pool_mib", 5000},
                                                  {"epsilon", -0.1}, {"lookup", "binary"}, {"filter", "vsm"}});
    // In range, but a box of 4 taps has no centre texel: refused when the light's
    // technique is created, before anything renders.
    const config::RenderConfig cfg = panesConfig(scene::LightType::Spot);
    const auto expectRefusal = [&](const nlohmann::json& params, const std::string& name, const std::string& why) {
        try {
            renderDeep(cfg, test::panesScene({1.0f}, 0.3f), params);
            ADD_FAILURE() << "rendered with " << params.dump();
        } catch (const Error& e) {
            EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
            EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
        }
    };
    expectRefusal({{"pcf_kernel", 4}}, "pcf_kernel", "odd");
    // A pool larger than the device binds as one storage buffer (lavapipe: 128 MiB).
    if (context->properties().limits.maxStorageBufferRange < (4000ull << 20))
        expectRefusal({{"pool_mib", 4000}, {"max_pool_mib", 4000}}, "pool_mib", "maxStorageBufferRange");
    // A cap below the starting pool.
    expectRefusal({{"pool_mib", 64}, {"max_pool_mib", 32}}, "max_pool_mib", "at least 64");
}

} // namespace
