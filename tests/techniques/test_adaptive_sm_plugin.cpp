// The adaptive shadow map plugin (plugins/adaptive-sm) end to end: a uniform tree gives
// the conventional map's image (no seams, one compare and PCF across tile borders), the
// depth-range culling is exact, close-ups of a small object under a distant light against
// conventional maps of the same and of four times the memory, convergence over frames of
// a still view, the memory budget with eviction along a camera path, a moved caster
// redrawing only its tiles, the debug views, and refusals.
#include "PluginFrame.h"
#include "TestConfigs.h"
#include "TestContext.h"
#include "TestPaths.h"

#include "penumbra/config/Config.h"
#include "penumbra/core/Error.h"
#include "penumbra/metrics/ImageComparison.h"
#include "penumbra/scene/Generators.h"

#include <gtest/gtest.h>

#include <fmt/format.h>
#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <string>
#include <vector>

using namespace penumbra;

namespace {

double figure(const frame::FrameTimings& timings, const std::string& name)
{
    if (!timings.techniques.empty())
        for (const plugin::TechniqueFigure& f : timings.techniques[0])
            if (f.name == name) return f.value;
    ADD_FAILURE() << "no figure " << name;
    return 0.0;
}

// Pixels with geometry where |a - b| > threshold.
size_t differing(const std::vector<float>& a, const std::vector<float>& b, const test::RenderedFrame& f,
                 float threshold)
{
    size_t n = 0;
    for (size_t i = 0; i < a.size(); ++i)
        if (f.hasGeometry(i) && std::abs(a[i] - b[i]) > threshold) ++n;
    return n;
}

// The thesis' case at test size: a 1 m lattice (10 x 10 holes of 7 cm) standing in a
// 40 m room under a distant spot light whose cone covers the room (config/adaptive-sm.json),
// seen along a path that closes in on its shadow.
config::RenderConfig roomConfig()
{
    config::RenderConfig cfg = config::loadConfig(test::sourceDir() / "config/adaptive-sm.json");
    cfg.width = 160;
    cfg.height = 90;
    return cfg;
}

// Camera positions from far to near, all looking at the lattice's shadow.
scene::Camera pathCamera(const config::RenderConfig& cfg, float t)
{
    scene::Camera c = cfg.camera;
    const glm::vec3 far(4.0f, 6.0f, 9.0f);
    c.position = glm::mix(far, cfg.camera.position, t);
    return c;
}

class AdaptiveSm : public test::PluginGpuTest {
protected:
    // The frame's V after it was drawn (and settled, unless settle_rounds is 0).
    std::vector<float> renderAsm(config::RenderConfig cfg, scene::Scene scene, nlohmann::json params)
    {
        test::setShadow(cfg.lights[0], "adaptive-sm", params);
        render(cfg, std::move(scene));
        return frame->checkedVisibility();
    }
    std::vector<float> renderWith(config::RenderConfig cfg, scene::Scene scene, const std::string& technique,
                                  const nlohmann::json& params)
    {
        test::setShadow(cfg.lights[0], technique, params);
        render(cfg, std::move(scene));
        return frame->checkedVisibility();
    }
    // The next frame of the frame's renderer with `cfg`'s camera (and lights).
    std::vector<float> nextFrame(const config::RenderConfig& cfg, const std::vector<uint32_t>& moved = {})
    {
        frame->renderer.update(cfg, frame->scene, moved);
        frame->timings = frame->renderer.renderFrame();
        frame->positions = frame->renderer.readPositions();
        return frame->checkedVisibility();
    }
};

} // namespace

// Levels base_level = max_level = L: every cell of level L resident, a uniform grid of
// tiles that together form a (tile * 2^L)² map. Its image is the conventional map's of
// that resolution: texel for texel the same compares, PCF taps that leave a tile read the
// neighbour. A seam (a tap clamped at a tile's border, a half-texel shift) would differ
// along every border the shadows cross.
TEST_F(AdaptiveSm, UniformTreeGivesTheConventionalMapsImage)
{
    for (const scene::LightType type : {scene::LightType::Spot, scene::LightType::Directional, scene::LightType::Point}) {
        for (const int kernel : {1, 3, 5}) {
            // hard's PCF reads a cube face's guard band past its edges, the tiles clamp to
            // the face: cube maps are compared with one compare.
            if (type == scene::LightType::Point && kernel > 1) continue;
            SCOPED_TRACE(fmt::format("{}, pcf {}", scene::lightTypeName(type), kernel));
            config::RenderConfig cfg = test::defaultTestConfig();
            cfg.width = 200;
            cfg.height = 120;
            test::setLightType(cfg.lights[0], type);
            const scene::Scene scene = config::buildScene(cfg.scene);
            nlohmann::json hard = {{"resolution", 512}};
            if (kernel > 1) hard.update({{"filter", "pcf"}, {"pcf_kernel", kernel}});
            const std::vector<float> conventional = renderWith(cfg, scene, "hard", hard);
            // 64² tiles, level 3: 85 tiles a face, in 2 MiB (128 slots) or 8 MiB for six faces.
            const bool cube = type == scene::LightType::Point;
            const std::vector<float> tiled = renderAsm(cfg, scene, {{"tile_texels", 64}, {"base_level", 3},
                                                                    {"max_level", 3}, {"memory_mib", cube ? 8 : 2},
                                                                    {"pcf_kernel", kernel}});
            EXPECT_EQ(figure(frame->timings, "resident_tiles"), cube ? 6 * 85.0 : 85.0);
            size_t shadowed = 0;
            for (float v : conventional) shadowed += v < 0.5f ? 1 : 0;
            ASSERT_GT(shadowed, size_t(cfg.width * cfg.height / 20));
            // The tiles' crop transforms round the casters' vertices differently from the
            // whole map's, so a texel centre exactly on a caster's edge could flip; none
            // did here (0 pixels, both lights, every kernel). Bound: 0.02 % of the pixels.
            // A seam (PCF taps clamped to their tile) costs 15-49 of them here.
            const size_t diff = differing(tiled, conventional, *frame, 1e-3f);
            EXPECT_LE(diff, size_t(cfg.width * cfg.height) / 5000) << diff << " pixels differ";
        }
    }
}

// The thesis' min-max depth culling stops a lookup early only where the subtree's range
// decides it: the same image bit for bit, one compare and PCF.
TEST_F(AdaptiveSm, DepthCullingIsExact)
{
    const config::RenderConfig cfg = roomConfig();
    const scene::Scene scene = config::buildScene(cfg.scene);
    for (const int kernel : {1, 3}) {
        SCOPED_TRACE(kernel);
        const std::vector<float> culled = renderAsm(cfg, scene, {{"pcf_kernel", kernel}});
        const double tiles = figure(frame->timings, "resident_tiles");
        const std::vector<float> walked = renderAsm(cfg, scene, {{"pcf_kernel", kernel}, {"depth_culling", false}});
        EXPECT_EQ(figure(frame->timings, "resident_tiles"), tiles);  // the same tree
        EXPECT_EQ(culled, walked);
    }
}

// Close-ups of a small object under a distant light (the thesis' Fig. 2.12-2.14): wrong
// pixels (|V - V_ref| > 0.5 against the ray-traced hard shadow of the light's centre)
// along a path that closes in, ASM at 16 MiB against conventional maps of 16 MiB (2048²)
// and of 64 MiB (4096²).
TEST_F(AdaptiveSm, CloseUpsHaveFewerWrongPixelsThanConventionalMaps)
{
    config::RenderConfig cfg = roomConfig();
    const scene::Scene scene = config::buildScene(cfg.scene);
    std::string table;
    for (const float t : {0.0f, 0.6f, 1.0f}) {
        SCOPED_TRACE(t);
        cfg.camera = pathCamera(roomConfig(), t);
        const std::vector<float> reference = renderWith(cfg, scene, "reference", {{"samples", 1}, {"cache", false}});
        const auto wrong = [&](const std::vector<float>& v) { return differing(v, reference, *frame, 0.5f); };
        const size_t map2048 = wrong(renderWith(cfg, scene, "hard", {{"resolution", 2048}}));
        const size_t map4096 = wrong(renderWith(cfg, scene, "hard", {{"resolution", 4096}}));
        const size_t adaptive = wrong(renderAsm(cfg, scene, {{"memory_mib", 16}}));
        EXPECT_LE(figure(frame->timings, "tile_memory_mib"), 16.0);
        table += fmt::format("t {:.1f}: 2048² {} | 4096² {} | ASM 16 MiB {} (level {})\n", t, map2048, map4096,
                             adaptive, figure(frame->timings, "deepest_level"));
        // Far away the eye needs no more than the 2048² map gives, and the tree stops
        // near that (two texels a pixel); no worse than the map of equal memory beyond
        // a few edge pixels.
        EXPECT_LE(adaptive, map2048 + map2048 / 4 + 5) << table;
        if (t == 1.0f) {
            // The close-up: the goal is 4x fewer wrong pixels than the map of equal
            // memory, and fewer than the map of four times the memory.
            EXPECT_GT(map2048, 100u) << table;
            EXPECT_LE(4 * adaptive, map2048) << table;
            EXPECT_LT(adaptive, map4096) << table;
        }
    }
    std::cout << table;
}

// Progressive: with one refinement step per frame (settle_rounds 0) a still view keeps
// improving, frame after frame, to the image a settled frame gives.
TEST_F(AdaptiveSm, ConvergesWhileTheCameraIsStill)
{
    const config::RenderConfig cfg = roomConfig();
    const scene::Scene scene = config::buildScene(cfg.scene);
    const std::vector<float> reference = renderWith(cfg, scene, "reference", {{"samples", 1}, {"cache", false}});
    const std::vector<float> settled = renderAsm(cfg, scene, {{"settle_rounds", 15}});
    const size_t settledWrong = differing(settled, reference, *frame, 0.5f);
    std::vector<float> v = renderAsm(cfg, scene, {{"settle_rounds", 0}, {"refine_ms", 0}});
    EXPECT_EQ(frame->timings.redraws, 0u);
    std::vector<size_t> wrong{differing(v, reference, *frame, 0.5f)};
    std::vector<double> tiles{figure(frame->timings, "resident_tiles")};
    for (int f = 0; f < 40; ++f) {
        v = nextFrame(cfg);
        wrong.push_back(differing(v, reference, *frame, 0.5f));
        tiles.push_back(figure(frame->timings, "resident_tiles"));
        // One step per frame, one tile per step (refine_ms 0): the tree grows by at most one.
        EXPECT_LE(figure(frame->timings, "tiles_created"), 1.0);
        EXPECT_EQ(figure(frame->timings, "refine_steps"), 1.0);
        if (figure(frame->timings, "cells_asking") == 0) break;
    }
    const std::string trace = fmt::format("wrong pixels per frame {}, tiles {}, settled {}", fmt::join(wrong, " "),
                                          fmt::join(tiles, " "), settledWrong);
    EXPECT_GT(wrong.front(), 4 * std::max<size_t>(wrong.back(), 1)) << trace;
    EXPECT_GT(tiles.back(), tiles.front() + 5) << trace;
    EXPECT_LE(wrong.back(), settledWrong + settledWrong / 10 + 5) << trace;
}

// A small budget along a path that sees two places: the atlas holds exactly memory_mib,
// the tree never outgrows it, nodes of the first place go (LRU) for the second, and the
// second place's image is as good as a fresh one's.
TEST_F(AdaptiveSm, MemoryBudgetIsHonouredWithEviction)
{
    config::RenderConfig cfg = roomConfig();
    const scene::Scene scene = config::buildScene(cfg.scene);
    // 64² tiles: 16 KiB each, 128 in 2 MiB, 85 of them the base (levels 0 .. 3: 512²).
    // Four texels a pixel: a view asks for more than the rest holds.
    const nlohmann::json params = {{"memory_mib", 2}, {"tile_texels", 64}, {"base_level", 3}, {"texels_per_pixel", 4}};
    renderAsm(cfg, scene, params);
    EXPECT_EQ(figure(frame->timings, "atlas_mib"), 2.0);
    EXPECT_EQ(figure(frame->timings, "atlas_slots"), 128.0);
    EXPECT_GT(figure(frame->timings, "resident_tiles"), 100.0);
    // Across the room, where the lattice's shadow is out of view: another place's edges
    // (the lattice itself, its shadow on its far side).
    config::RenderConfig other = cfg;
    other.camera.position = {-1.5f, 1.0f, -1.8f};
    other.camera.target = {0.0f, 0.6f, 0.0f};
    for (int f = 0; f < 4; ++f) {
        nextFrame(f % 2 ? cfg : other);
        EXPECT_LE(figure(frame->timings, "resident_tiles"), 128.0);
        EXPECT_LE(figure(frame->timings, "tile_memory_mib"), 2.0);
    }
    EXPECT_GT(figure(frame->timings, "evictions_total"), 0.0);
    // Back: the first view again, refined anew within the same memory.
    const std::vector<float> back = nextFrame(cfg);
    const std::vector<float> reference = renderWith(cfg, scene, "reference", {{"samples", 1}, {"cache", false}});
    const std::vector<float> fresh = renderAsm(cfg, scene, params);
    const size_t wrongBack = differing(back, reference, *frame, 0.5f), wrongFresh = differing(fresh, reference, *frame, 0.5f);
    EXPECT_LE(wrongBack, wrongFresh + wrongFresh / 5 + 10) << wrongBack << " against " << wrongFresh;
}

// A caster that moves invalidates the tiles over where it was and where it is (the BVH's
// moved instances), not the tree: the next frame shows it at its new place.
TEST_F(AdaptiveSm, AMovedCasterRedrawsOnlyTheTilesItTouches)
{
    config::RenderConfig cfg = test::defaultTestConfig();
    cfg.width = 160;
    cfg.height = 90;
    scene::Scene scene = config::buildScene(cfg.scene);
    uint32_t sphere = UINT32_MAX;
    for (uint32_t i = 0; i < scene.instances.size(); ++i)
        if (scene.graph.node(scene.instances[i].node).name == "sphere") sphere = i;
    ASSERT_NE(sphere, UINT32_MAX);
    renderAsm(cfg, scene, {});
    const double resident = figure(frame->timings, "resident_tiles");
    // Move the sphere by 2 units in the frame's own scene, as an animation does.
    scene::Scene& live = frame->scene;
    const uint32_t node = live.instances[sphere].node;
    live.graph.setLocal(node, glm::translate(glm::mat4(1.0f), {0.0f, 0.0f, 2.0f}) * live.graph.local(node));
    const std::vector<uint32_t> moved = live.updateTransforms();
    ASSERT_FALSE(moved.empty());
    const std::vector<float> after = nextFrame(cfg, moved);
    const double invalidated = figure(frame->timings, "tiles_invalidated");
    EXPECT_GE(invalidated, 3.0);  // at least the root's and a path down
    EXPECT_LT(invalidated, 0.6 * resident);
    // Against the hard map of the same scene after the move (fine shadow details aside:
    // only the coarse shape is compared, pixels that differ by > 0.5).
    scene::Scene movedScene = config::buildScene(cfg.scene);
    movedScene.graph.setLocal(movedScene.instances[sphere].node,
                              glm::translate(glm::mat4(1.0f), {0.0f, 0.0f, 2.0f}) *
                                  movedScene.graph.local(movedScene.instances[sphere].node));
    movedScene.updateTransforms();
    const std::vector<float> hard = renderWith(cfg, std::move(movedScene), "hard", {{"resolution", 2048}});
    EXPECT_LE(differing(after, hard, *frame, 0.5f), size_t(cfg.width * cfg.height) / 200);
}

// The debug views: every pixel's tile level within [0, max level], the light view's
// resident tiles with borders and the levels the figures report.
TEST_F(AdaptiveSm, DebugViewsShowTheTree)
{
    config::RenderConfig cfg = roomConfig();
    test::setShadow(cfg.lights[0], "adaptive-sm", {});
    const std::string prefix = "light0.adaptive-sm.";
    render(cfg, config::buildScene(cfg.scene),
           {prefix + "tile_level", prefix + "resident_tiles", prefix + "tile_benefit"});
    const double deepest = figure(frame->timings, "deepest_level");
    const std::vector<float> level = frame->renderer.readImage(prefix + "tile_level").values;
    float top = -1.0f;
    for (size_t i = 0; i < level.size(); ++i) {
        if (!frame->hasGeometry(i)) continue;
        EXPECT_GE(level[i], 2.0f);  // the base level at least
        top = std::max(top, level[i]);
    }
    EXPECT_EQ(double(top), deepest);
    const std::vector<float> resident = frame->renderer.readImage(prefix + "resident_tiles").values;
    EXPECT_EQ(resident.size(), 512u * 512u);
    // 512 texels across: a cell of level 8 is two wide and keeps one texel of its level.
    EXPECT_EQ(double(*std::ranges::max_element(resident)), std::min(deepest, 8.0) + 1.0);
    EXPECT_EQ(*std::ranges::min_element(resident), 0.0f);  // borders
    const std::vector<float> benefit = frame->renderer.readImage(prefix + "tile_benefit").values;
    EXPECT_GE(*std::ranges::min_element(benefit), 0.0f);
}

TEST_F(AdaptiveSm, RefusesWhatItCannotDo)
{
    const auto refusal = [&](config::RenderConfig cfg, const nlohmann::json& params) -> std::string {
        try {
            renderAsm(cfg, config::buildScene(cfg.scene), params);
        } catch (const std::exception& e) {
            return e.what();
        }
        return "";
    };
    config::RenderConfig cfg = test::defaultTestConfig();
    cfg.width = 32;
    cfg.height = 24;
    std::string what = refusal(cfg, {{"tile_texels", 100}});
    EXPECT_NE(what.find("tile_texels"), std::string::npos) << what;
    what = refusal(cfg, {{"memory_mib", 1}, {"tile_texels", 128}, {"base_level", 2}});  // 21 tiles in 16 slots
    EXPECT_NE(what.find("base_level"), std::string::npos) << what;
    config::RenderConfig point = cfg;
    test::setLightType(point.lights[0], scene::LightType::Point);
    what = refusal(point, {{"memory_mib", 1}, {"tile_texels", 128}, {"base_level", 1}});  // 6 x 5 tiles in 16 slots
    EXPECT_NE(what.find("base_level"), std::string::npos) << what;
    what = refusal(cfg, {{"base_level", 4}, {"max_level", 3}});
    EXPECT_NE(what.find("max_level"), std::string::npos) << what;
    what = refusal(cfg, {{"pcf_kernel", 4}});
    EXPECT_NE(what.find("pcf_kernel"), std::string::npos) << what;
}

// Nothing depends on absolute units: the default scene at 1e-3 and 1e5 of its size refines
// the same tree and shows the same shadows. (Not the room: its 2048² and 4096² maps alias
// the lattice's holes, and at 1e5 the casters' rounding moves which texel centres the bars
// cover: `hard` differs there on 415 pixels of 14,400, all in the aliased pattern.) (the pixel footprints and texel sizes are compared
// in light-view uv; the biases are the rasterizer's, relative to depth).
TEST_F(AdaptiveSm, SameShadowsAtScales1em3And1e5)
{
    config::RenderConfig cfg = test::defaultTestConfig();
    cfg.width = 160;
    cfg.height = 90;
    const std::vector<float> base = renderAsm(cfg, config::buildScene(cfg.scene), {});
    const double tiles = figure(frame->timings, "resident_tiles");
    for (const float s : {1e-3f, 1e5f}) {
        SCOPED_TRACE(s);
        config::RenderConfig scaled = cfg;
        test::scaleConfig(scaled, s);
        scene::Scene scene = config::buildScene(cfg.scene);
        scene::scaleScene(scene, s);
        const std::vector<float> v = renderAsm(scaled, std::move(scene), {});
        // A few edge pixels flip with the G-buffer's rounding at another scale (56 and 52 tiles
        // at 1 and 1e5): the tree is the same within 10 %.
        EXPECT_NEAR(figure(frame->timings, "resident_tiles"), tiles, 0.1 * tiles);
        EXPECT_LE(differing(v, base, *frame, 0.5f), size_t(cfg.width * cfg.height) / 200);
    }
}

// Light at 80 and 87 degrees from the ground's normal over a bare ground: no acne (the
// slope-scaled bias of each tile follows its own texel size), so nothing to refine either.
TEST_F(AdaptiveSm, GrazingLightLeavesABareGroundLit)
{
    config::RenderConfig cfg = test::defaultTestConfig();
    cfg.width = 160;
    cfg.height = 90;
    test::setLightType(cfg.lights[0], scene::LightType::Directional);
    for (const float degrees : {80.0f, 87.0f}) {
        SCOPED_TRACE(degrees);
        const float a = glm::radians(degrees);
        cfg.lights[0].light.direction = glm::normalize(glm::vec3(std::sin(a), -std::cos(a), 0.3f * std::sin(a)));
        const std::vector<float> reference = [&] {
            test::setShadow(cfg.lights[0], "reference", {{"samples", 1}, {"cache", false}});
            render(cfg, test::planeScene());
            return frame->checkedVisibility();
        }();
        const std::vector<float> v = renderAsm(cfg, test::planeScene(), {});
        EXPECT_EQ(differing(v, reference, *frame, 0.05f), 0u);
        EXPECT_EQ(figure(frame->timings, "tiles_created"), 0.0);
    }
}

// A box standing on the ground: its shadow starts at its foot (contact), as the
// ray-traced reference's does, however far the tree refines there.
TEST_F(AdaptiveSm, ContactShadowReachesTheFoot)
{
    config::RenderConfig cfg = test::boxOnGroundConfig();
    cfg.width = 160;
    cfg.height = 120;
    test::setLightType(cfg.lights[0], scene::LightType::Spot);
    cfg.lights[0].light.position = {-3.0f, 3.0f, 0.5f};
    cfg.lights[0].light.direction = glm::normalize(-cfg.lights[0].light.position);
    test::setShadow(cfg.lights[0], "reference", {{"samples", 1}, {"cache", false}});
    render(cfg, test::boxOnGroundScene());
    const std::vector<float> reference = frame->checkedVisibility();
    for (const int kernel : {1, 3}) {
        SCOPED_TRACE(kernel);
        const std::vector<float> v = renderAsm(cfg, test::boxOnGroundScene(), {{"pcf_kernel", kernel}});
        // Shadow edges: at most the pixels a texel of the finest level straddles.
        EXPECT_LE(differing(v, reference, *frame, 0.5f), size_t(cfg.width * cfg.height) / 400);
    }
}

// PCF taps that leave the centre's tile read the tree no finer than the centre's level:
// a finer neighbour's tile carries the bias of its own, smaller texel, and a sloped ground
// compared one coarse texel away from its own depth failed against it, a dark line of 1/k²
// along the border of every refined region (issue 43: config/default.json, pcf_kernel 3).
// Ground pixels whose whole neighbourhood one compare finds lit stay lit under PCF.
TEST_F(AdaptiveSm, PcfAcrossTheBorderOfARefinedRegionLeavesLitGroundLit)
{
    for (const scene::LightType type : {scene::LightType::Spot, scene::LightType::Directional}) {
        config::RenderConfig cfg = test::defaultTestConfig();
        test::setLightType(cfg.lights[0], type);
        const scene::Scene scene = config::buildScene(cfg.scene);
        const std::vector<float> one = renderAsm(cfg, scene, {{"pcf_kernel", 1}});
        // Borders to cross: the tree refined past its always-resident levels.
        EXPECT_GT(figure(frame->timings, "deepest_level"), 2.0);
        const int w = int(cfg.width), h = int(cfg.height), r = 3;
        const auto litAround = [&](int x, int y) {
            for (int dy = -r; dy <= r; ++dy)
                for (int dx = -r; dx <= r; ++dx) {
                    const size_t p = size_t(y + dy) * size_t(w) + size_t(x + dx);
                    if (!frame->onGround(p) || one[p] != 1.0f) return false;
                }
            return true;
        };
        for (const int kernel : {3, 5}) {
            SCOPED_TRACE(fmt::format("{}, pcf {}", scene::lightTypeName(type), kernel));
            const std::vector<float> v = renderAsm(cfg, scene, {{"pcf_kernel", kernel}});
            size_t darkened = 0;
            for (int y = r; y < h - r; ++y)
                for (int x = r; x < w - r; ++x)
                    if (v[size_t(y) * size_t(w) + size_t(x)] < 1.0f && litAround(x, y)) ++darkened;
            EXPECT_EQ(darkened, 0u);
        }
    }
}
