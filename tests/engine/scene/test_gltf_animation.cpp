// glTF animations: read into Scene::animations (scene/NodeAnimation.h), sampled with each
// interpolation, played by a config ("scene": {"animation": ...}) through poseScene.
#include "ScratchFolder.h"
#include "TestPaths.h"  // support/: the build tree's paths

#include "penumbra/config/Config.h"
#include "penumbra/core/Error.h"
#include "penumbra/scene/GltfLoader.h"

#include <glm/gtc/quaternion.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <unistd.h>

using namespace penumbra;
using nlohmann::json;
namespace fs = std::filesystem;

namespace {

fs::path animatedFile() { return penumbra::test::testDataDir() / "gltf" / "animated.gltf"; }

scene::Scene loadAnimated(scene::GltfLoadReport& report) { return scene::loadGltf(animatedFile(), report); }

const scene::NodeChannel& channel(const scene::NodeAnimation& clip, scene::ChannelPath path)
{
    for (const scene::NodeChannel& c : clip.channels) {
        if (c.path == path) return c;
    }
    throw Error("no such channel");
}

void expectVec(const glm::vec4& got, const glm::vec4& want, float tolerance = 1e-5f)
{
    for (int i = 0; i < 4; ++i) EXPECT_NEAR(got[i], want[i], tolerance) << "component " << i;
}

} // namespace

TEST(GltfAnimation, ClipsAreReadWithTheirChannelsAndRestPoses)
{
    scene::GltfLoadReport report;
    const scene::Scene s = loadAnimated(report);
    ASSERT_EQ(s.animations.size(), 2u);
    EXPECT_EQ(s.animations[0].name, "wave");
    EXPECT_EQ(s.animations[1].name, "spin");
    EXPECT_EQ(s.animations[0].channels.size(), 3u);
    EXPECT_FLOAT_EQ(s.animations[0].duration(), 2.0f);
    EXPECT_FLOAT_EQ(s.animations[1].duration(), 1.0f);
    ASSERT_EQ(s.animations[0].rest.size(), 1u);
    EXPECT_EQ(s.animations[0].rest[0].translation, glm::vec3(0.0f));
    EXPECT_EQ(channel(s.animations[0], scene::ChannelPath::Scale).interpolation, scene::KeyInterpolation::CubicSpline);
    EXPECT_TRUE(report.warnings.empty()) << report.warnings.front();
}

TEST(GltfAnimation, EachInterpolationSamplesAsGltfDefinesIt)
{
    scene::GltfLoadReport report;
    const scene::Scene s = loadAnimated(report);
    const scene::NodeAnimation& wave = s.animations[0];
    // LINEAR translation (0,0,0) -> (4,2,0) over 2 s; held before the first and after the last key.
    const scene::NodeChannel& t = channel(wave, scene::ChannelPath::Translation);
    expectVec(scene::sample(t, 1.0f), {2, 1, 0, 0});
    expectVec(scene::sample(t, -5.0f), {0, 0, 0, 0});
    expectVec(scene::sample(t, 9.0f), {4, 2, 0, 0});
    // STEP rotation: identity until the key at 1 s, then a quarter turn about +Y.
    const scene::NodeChannel& r = channel(wave, scene::ChannelPath::Rotation);
    const float h = std::sqrt(0.5f);
    expectVec(scene::sample(r, 0.999f), {0, 0, 0, 1});
    expectVec(scene::sample(r, 1.0f), {0, h, 0, h});
    // CUBICSPLINE scale 1 -> 3 with zero tangents: Hermite's smoothstep, 2 half-way.
    const scene::NodeChannel& sc = channel(wave, scene::ChannelPath::Scale);
    expectVec(scene::sample(sc, 1.0f), {2, 2, 2, 0});
    const float u = 0.25f, smooth = 3 * u * u - 2 * u * u * u;
    expectVec(scene::sample(sc, 0.5f), glm::vec4(glm::vec3(1.0f + 2.0f * smooth), 0.0f));
    // LINEAR rotation is a slerp: an eighth of a turn half-way, of unit length.
    const scene::NodeChannel& spin = s.animations[1].channels[0];
    const float c = std::cos(glm::radians(22.5f)), sn = std::sin(glm::radians(22.5f));
    expectVec(scene::sample(spin, 0.5f), {0, sn, 0, c});
}

TEST(GltfAnimation, AConfigPlaysTheFileAnimationItNamesAtAnyScale)
{
    for (const float scale : {1.0f, 1e-3f, 1e5f}) {
        SCOPED_TRACE(scale);
        const json doc = {{"scene", {{"gltf", animatedFile().string()}, {"animation", "wave"}, {"scale", scale}}},
                          {"camera", {{"position", {0, 5, 10}}, {"target", {0, 0, 0}}}},
                          {"lights", json::array({{{"type", "directional"}, {"direction", {0, -1, 0}}}})}};
        config::PreparedRun run = config::prepareRun(config::parseConfig(doc, "anim.json"), {});
        EXPECT_TRUE(config::animated(run.rest));
        EXPECT_FLOAT_EQ(config::animationDuration(run.rest, run.scene), 2.0f);
        const glm::vec3 rest = run.scene.instances[0].worldBounds.center();
        EXPECT_NEAR(glm::length(rest), 0.0f, 1e-6f * scale);
        const std::vector<uint32_t> moved = run.poseAt(1.0f);
        EXPECT_EQ(moved.size(), 1u);
        // Translated by (2, 1, 0), times the scene's scale; scaled 2 about that point.
        const scene::Aabb b = run.scene.instances[0].worldBounds;
        EXPECT_NEAR(b.center().x, 2.0f * scale, 1e-5f * scale);
        EXPECT_NEAR(b.center().y, 1.0f * scale, 1e-5f * scale);
        EXPECT_NEAR(b.extent().x, 4.0f * scale, 1e-4f * scale);  // the 2 x 2 quad, scaled 2 (and turned a quarter)
        run.poseAt(0.0f);
        EXPECT_NEAR(glm::length(run.scene.instances[0].worldBounds.center()), 0.0f, 1e-5f * scale);
    }
}

TEST(GltfAnimation, TheAnimationIsNamedOrIndexedAndAnUnknownOneIsAConfigError)
{
    json doc = {{"scene", {{"gltf", animatedFile().string()}, {"animation", 1}}},
                {"camera", {{"position", {0, 5, 10}}, {"target", {0, 0, 0}}}},
                {"lights", json::array({{{"type", "directional"}, {"direction", {0, -1, 0}}}})}};
    config::PreparedRun run = config::prepareRun(config::parseConfig(doc, "anim.json"), {});
    EXPECT_EQ(config::playedClips(run.rest, run.scene), std::vector<size_t>{1});
    EXPECT_FLOAT_EQ(config::animationDuration(run.rest, run.scene), 1.0f);
    // Written back as given, and read into the same run.
    EXPECT_EQ(config::configJson(run.rest, "x.json")["scene"]["animation"], "1");

    doc["scene"]["animation"] = "nope";
    try {
        config::prepareRun(config::parseConfig(doc, "anim.json"), {});
        FAIL() << "an unknown animation was accepted";
    } catch (const ConfigError& e) {
        const std::string what = e.what();
        EXPECT_NE(what.find("/scene/animation"), std::string::npos) << what;
        EXPECT_NE(what.find("\"wave\", \"spin\""), std::string::npos) << what;
    }
    doc["scene"]["animation"] = -1;
    EXPECT_THROW(config::parseConfig(doc, "anim.json"), ConfigError);
    doc["scene"] = {{"generator", "box-grid"}, {"animation", "wave"}};
    EXPECT_THROW(config::parseConfig(doc, "anim.json"), ConfigError);
}

TEST(GltfAnimation, AChannelThatCannotPlayIsLeftOutWithAWarningThatNamesIt)
{
    std::ifstream in(animatedFile());
    json gltf = json::parse(in);
    // Times 2 then 0 for the translation, morph weights for another channel.
    gltf["animations"][0]["channels"][1]["target"]["path"] = "weights";
    const test::ScratchFolder scratch("anim");
    const fs::path& dir = scratch.path;
    // The translation sampler gets a decreasing input: 2 (the end of its own times), then 0.
    gltf["accessors"].push_back({{"bufferView", 2}, {"byteOffset", 4}, {"componentType", 5126}, {"count", 2}, {"type", "SCALAR"}});
    gltf["animations"][0]["samplers"][0]["input"] = gltf["accessors"].size() - 1;
    std::ofstream(dir / "broken.gltf") << gltf.dump();
    scene::GltfLoadReport report;
    const scene::Scene s = scene::loadGltf(dir / "broken.gltf", report);
    ASSERT_EQ(s.animations.size(), 2u);
    EXPECT_EQ(s.animations[0].channels.size(), 1u);  // the scale channel alone
    std::string all;
    for (const std::string& w : report.warnings) all += w + "\n";
    EXPECT_NE(all.find("/animations/0/channels/0"), std::string::npos) << all;
    EXPECT_NE(all.find("increase strictly"), std::string::npos) << all;
    EXPECT_NE(all.find("/animations/0/channels/1"), std::string::npos) << all;
    EXPECT_NE(all.find("morph target weights"), std::string::npos) << all;
}
