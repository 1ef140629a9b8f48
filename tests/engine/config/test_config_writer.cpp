// config::configJson / saveConfig (config/ConfigWriter.h): a config written back reads
// into the same run, for every shipped config and every light type and animation form.
#include "ScratchFolder.h"
#include "TestPaths.h"  // support/: the build tree's paths

#include "penumbra/config/Config.h"
#include "penumbra/core/Error.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <fstream>
#include <unistd.h>

using namespace penumbra;
using nlohmann::json;
namespace fs = std::filesystem;

namespace {

// A scratch folder with elsewhere/deeper/ in it: places to save a config away from the
// files it names.
struct TempFolder : test::ScratchFolder {
    TempFolder() : ScratchFolder("config_writer") { fs::create_directories(path / "elsewhere" / "deeper"); }
};

// What a run renders, compared field by field (configJson is itself compared as JSON
// below; this checks that the JSON means the same run).
void expectSameRun(const config::RenderConfig& a, const config::RenderConfig& b, const std::string& what)
{
    SCOPED_TRACE(what);
    EXPECT_EQ(a.scene.listed, b.scene.listed);
    ASSERT_EQ(a.scene.parts.size(), b.scene.parts.size());
    for (size_t i = 0; i < a.scene.parts.size(); ++i) {
        const config::ScenePart &x = a.scene.parts[i], &y = b.scene.parts[i];
        EXPECT_EQ(x.name, y.name);
        EXPECT_EQ(x.kind, y.kind);
        if (x.kind == config::ScenePart::Kind::Gltf) {
            EXPECT_TRUE(fs::equivalent(x.gltf, y.gltf)) << x.gltf << " vs " << y.gltf;
            ASSERT_EQ(x.allowedRoots.size(), y.allowedRoots.size());
            for (size_t r = 0; r < x.allowedRoots.size(); ++r) EXPECT_TRUE(fs::equivalent(x.allowedRoots[r], y.allowedRoots[r]));
        }
        EXPECT_EQ(x.generator, y.generator);
        EXPECT_EQ(x.params, y.params);
        EXPECT_EQ(x.animation, y.animation);
        // Doubles written as the shortest text that reads back exactly; a quaternion is
        // normalised again when read (its last bit may move).
        EXPECT_EQ(x.transform.translation, y.transform.translation);
        EXPECT_EQ(x.transform.rotationDeg, y.transform.rotationDeg);
        EXPECT_NEAR(glm::length(glm::dvec4(x.transform.rotation.x - y.transform.rotation.x, x.transform.rotation.y - y.transform.rotation.y,
                                           x.transform.rotation.z - y.transform.rotation.z, x.transform.rotation.w - y.transform.rotation.w)),
                    0.0, 1e-15);
        EXPECT_EQ(x.transform.scale, y.transform.scale);
    }
    EXPECT_EQ(a.camera.position, b.camera.position);
    EXPECT_EQ(a.camera.target, b.camera.target);
    EXPECT_EQ(a.camera.up, b.camera.up);
    EXPECT_EQ(a.camera.fovYDeg, b.camera.fovYDeg);
    EXPECT_EQ(a.camera.nearWorld, b.camera.nearWorld);
    EXPECT_EQ(a.lightsFromScene && a.lights.empty(), b.lightsFromScene && b.lights.empty());
    ASSERT_EQ(a.lights.size(), b.lights.size());
    for (size_t i = 0; i < a.lights.size(); ++i) {
        const scene::Light &x = a.lights[i].light, &y = b.lights[i].light;
        EXPECT_EQ(a.lights[i].name, b.lights[i].name);
        EXPECT_EQ(x.type, y.type);
        if (x.type != scene::LightType::Directional) {
            EXPECT_EQ(x.position, y.position);  // a sun has none
        }
        // A direction read back is normalised again: equal to the float's last bit or two.
        EXPECT_NEAR(glm::length(x.direction - y.direction), 0.0f, 1e-6f) << "light " << i;
        EXPECT_NEAR(glm::length(x.tangent - y.tangent), 0.0f, 1e-6f) << "light " << i;
        EXPECT_EQ(x.outerConeDeg, y.outerConeDeg);
        EXPECT_EQ(x.innerConeDeg, y.innerConeDeg);
        EXPECT_EQ(x.angularDiameterDeg, y.angularDiameterDeg);
        EXPECT_EQ(x.sizeWorld, y.sizeWorld);
        EXPECT_EQ(x.radiusWorld, y.radiusWorld);
        EXPECT_EQ(x.intensity, y.intensity);
        EXPECT_EQ(x.color, y.color);
        EXPECT_EQ(a.lights[i].shadow.technique, b.lights[i].shadow.technique);
        EXPECT_EQ(a.lights[i].shadow.required, b.lights[i].shadow.required);
        ASSERT_EQ(a.lights[i].shadow.params.size(), b.lights[i].shadow.params.size());
        for (size_t p = 0; p < a.lights[i].shadow.params.size(); ++p) {
            EXPECT_EQ(a.lights[i].shadow.params[p].name, b.lights[i].shadow.params[p].name);
            EXPECT_EQ(a.lights[i].shadow.params[p].value, b.lights[i].shadow.params[p].value);
        }
    }
    EXPECT_EQ(a.culling, b.culling);
    EXPECT_EQ(a.shadowFocus, b.shadowFocus);
    EXPECT_EQ(a.batchDraws, b.batchDraws);
    EXPECT_EQ(a.width, b.width);
    EXPECT_EQ(a.height, b.height);
    EXPECT_EQ(a.frames, b.frames);
    EXPECT_EQ(a.animation.fps, b.animation.fps);
    ASSERT_EQ(a.animation.tracks.size(), b.animation.tracks.size());
    for (size_t t = 0; t < a.animation.tracks.size(); ++t) {
        EXPECT_EQ(a.animation.tracks[t].target, b.animation.tracks[t].target);
        EXPECT_EQ(a.animation.tracks[t].interpolation, b.animation.tracks[t].interpolation);
        ASSERT_EQ(a.animation.tracks[t].keys.size(), b.animation.tracks[t].keys.size());
        for (size_t k = 0; k < a.animation.tracks[t].keys.size(); ++k) {
            EXPECT_EQ(a.animation.tracks[t].keys[k].timeS, b.animation.tracks[t].keys[k].timeS);
            EXPECT_EQ(a.animation.tracks[t].keys[k].value, b.animation.tracks[t].keys[k].value);
        }
    }
    EXPECT_EQ(a.notes, b.notes);
}

// Saves `config` at `file`, reads it back and checks that it is the same run.
config::RenderConfig roundTrip(const config::RenderConfig& config, const fs::path& file)
{
    config::saveConfig(config, file);
    const config::RenderConfig back = config::loadConfig(file);
    expectSameRun(config, back, file.string());
    return back;
}

} // namespace

TEST(ConfigWriter, EveryShippedConfigReadsBackAsTheSameRunFromAnyFolder)
{
    TempFolder temp;
    int checked = 0;
    for (const fs::path& root : {penumbra::test::sourceDir() / "config", penumbra::test::testDataDir() / "configs"}) {
        for (const auto& entry : fs::recursive_directory_iterator(root)) {
            if (entry.path().extension() != ".json" || entry.path().string().find("schema") != std::string::npos) continue;
            config::RenderConfig config;
            try {
                config = config::loadConfig(entry.path());
            } catch (const ConfigError&) {
                continue;  // the tests' deliberately broken configs
            }
            // Saved beside nothing it refers to: glTF paths must be rewritten for the new folder.
            roundTrip(config, temp.path / "elsewhere" / "deeper" / entry.path().filename());
            roundTrip(config, temp.path / entry.path().filename());
            ++checked;
        }
    }
    EXPECT_GE(checked, 20);
}

TEST(ConfigWriter, EveryLightTypeAndAnimationFormReadsBack)
{
    const json doc = json::parse(R"({
        "scene": {"generator": "box-grid", "params": {"columns": 3, "seed": 7}, "scale": 0.001},
        "camera": {"position": [1.5, 2.25, 3.1], "target": [0, 0.1, 0], "up": [0, 1, 0.01], "fov_y_deg": 50.5, "near": 0.01},
        "lights": [
            {"name": "sun", "type": "directional", "direction": [0.3, -1, 0.2], "angular_diameter_deg": 0.53,
             "intensity": 3.5, "shadow": {"technique": "pcss", "required": true}},
            {"type": "spot", "position": [0, 10, 0], "target": [0.5, 0, 0], "outer_cone_deg": 40, "inner_cone_deg": 12.25,
             "color": [1, 0.96, 0.9], "shadow": {"technique": "hard", "resolution": 1024, "depth_bias": 4.0}},
            {"type": "point", "position": [1, 4, 1], "radius": 0.25, "shadow": {"technique": "none"}},
            {"type": "rect", "position": [0, 6, 0], "direction": [0, -1, 0], "size": [2, 0.5], "tangent": [1, 0, 1],
             "shadow": {"technique": "vssm"}},
            {"type": "disk", "position": [2, 6, 0], "target": [2, 0, 0], "radius": 0.7}
        ],
        "culling": "receiver-mask", "shadow_focus": true, "draw_batching": "per-instance",
        "output": {"width": 321, "height": 123}, "frames": 4,
        "animation": {"fps": 24, "tracks": [
            {"target": "/camera/position", "interpolation": "smooth", "keys": [{"t": 0, "value": [1.5, 2.25, 3.1]}, {"t": 1.5, "value": [2, 2, 2]}]},
            {"target": "/lights/0/intensity", "interpolation": "step", "keys": [{"t": 0, "value": 3.5}, {"t": 0.1, "value": 0.7}]},
            {"target": "/lights/1/target", "keys": [{"t": 0.25, "value": [0, 0, 0]}]}
        ]},
        "notes": ["A paragraph."]
    })");
    TempFolder temp;
    const config::RenderConfig config = config::parseConfig(doc, temp.path / "all.json");
    const config::RenderConfig back = roundTrip(config, temp.path / "all.json");
    EXPECT_EQ(back.lights[0].shadow.required, true);
    EXPECT_TRUE(back.lights[1].target.has_value());  // aimed at a target as given, not turned into a direction
    EXPECT_FALSE(back.lights[3].target.has_value());

    // A light moved onto its target (the viewer's fields allow it) keeps its direction:
    // the reader refuses a target at the position.
    config::RenderConfig moved = config;
    moved.lights[1].light.position = *moved.lights[1].target;
    const config::RenderConfig movedBack = roundTrip(moved, temp.path / "moved.json");
    EXPECT_FALSE(movedBack.lights[1].target.has_value());

    // Shortest decimals: what a person wrote, not the float's binary expansion.
    const std::string text = config::configJson(config, temp.path / "all.json").dump();
    EXPECT_NE(text.find("[1.0,0.96,0.9]"), std::string::npos) << text;
    EXPECT_NE(text.find("0.001"), std::string::npos) << text;
    EXPECT_EQ(text.find("0.9599999"), std::string::npos) << text;
}

TEST(ConfigWriter, GltfLightsAreWrittenOutOnceResolvedAndAsTheSceneBeforeThat)
{
    TempFolder temp;
    config::RenderConfig config = config::loadConfig(penumbra::test::testDataDir() / "configs" / "gltf_scene_lights.json");
    const json before = config::configJson(config, temp.path / "x.json");
    EXPECT_EQ(before["lights"], "scene");
    roundTrip(config, temp.path / "x.json");

    config::buildScene(config);  // the file's three lights, named as the file names them
    ASSERT_EQ(config.lights.size(), 3u);
    const config::RenderConfig back = roundTrip(config, temp.path / "elsewhere" / "x.json");
    EXPECT_EQ(back.lights[0].name, config.lights[0].name);
}

// A scene of parts (a generator, glTF files turned by Euler angles and by a quaternion,
// scaled unevenly, one playing its animation) is saved as parts and reads back into the
// same scene: the same instances at the same world bounds, at rest and posed.
TEST(ConfigWriter, ScenePartsReadBackAndDrawTheSameScene)
{
    TempFolder temp;
    const fs::path file = temp.path / "parts.json";
    const fs::path shipped = penumbra::test::sourceDir() / "config";
    json doc = json::parse(std::ifstream(shipped / "gltf-over-ground.json"));
    for (json& part : doc["scene"]["parts"]) {
        if (part.contains("gltf")) part["gltf"] = (shipped / part["gltf"].get<std::string>()).string();
    }
    doc["scene"]["parts"].push_back({{"name", "turning"},
                                     {"gltf", (penumbra::test::testDataDir() / "gltf" / "animated.gltf").string()},
                                     {"animation", "spin"},
                                     {"translation", {-3.25, 0.1, 1e-3}},
                                     {"rotation", {0.1, 0.7, 0.0, 0.7}},
                                     {"scale", {1.5, 0.25, 3}}});
    std::ofstream(file) << doc.dump();
    const config::RenderConfig config = config::loadConfig(file);
    const config::RenderConfig back = roundTrip(config, temp.path / "elsewhere" / "deeper" / "parts.json");
    const json written = config::configJson(config, temp.path / "elsewhere" / "parts.json");
    EXPECT_EQ(written["scene"]["parts"][2]["rotation_deg"], json({0.0, 30.0, 0.0}));
    EXPECT_EQ(written["scene"]["parts"][3]["scale"], json({1.5, 0.25, 3.0}));
    EXPECT_EQ(written["scene"]["parts"][3]["animation"], "spin");

    config::PreparedRun a = config::prepareRun(config, {}), b = config::prepareRun(back, {});
    for (const float timeS : {0.0f, 0.4f}) {
        a.poseAt(timeS);
        b.poseAt(timeS);
        ASSERT_EQ(a.scene.instances.size(), b.scene.instances.size());
        for (size_t i = 0; i < a.scene.instances.size(); ++i) {
            // A quaternion is normalised again when read: its last bit may move.
            const scene::Aabb &x = a.scene.instances[i].worldBounds, &y = b.scene.instances[i].worldBounds;
            EXPECT_LE(glm::length(x.min - y.min) + glm::length(x.max - y.max), 1e-6f * glm::length(x.extent())) << i;
        }
    }
}

TEST(ConfigWriter, ASaveThatCannotBeWrittenNamesThePath)
{
    // The write itself is io::writeTextFile's (all or nothing: tests/engine/io).
    TempFolder temp;
    const config::RenderConfig config = config::loadConfig(penumbra::test::sourceDir() / "config" / "default.json");
    for (const fs::path& bad : {temp.path / "missing-folder" / "x.json", temp.path / "elsewhere"}) {
        try {
            config::saveConfig(config, bad);
            ADD_FAILURE() << "saved as " << bad;
        } catch (const Error& e) {
            EXPECT_NE(std::string(e.what()).find(bad.string()), std::string::npos) << e.what();
        }
    }
}
