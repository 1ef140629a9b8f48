// The viewer's parts that need no window (apps/penumbra-viewer/): camera moves
// (CameraControl.h) at scene scales from 1e-3 to 1e5, script parsing (Script.h) and shader
// watching (ShaderWatcher.h).
#include "CameraControl.h"
#include "Script.h"
#include "ShaderWatcher.h"

#include "penumbra/core/Error.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <unistd.h>

using namespace penumbra;
using namespace penumbra::viewer;

namespace {

scene::Camera cameraAt(float scale)
{
    scene::Camera c;
    c.position = glm::vec3(3.0f, 2.0f, 4.0f) * scale;
    c.target = glm::vec3(0.5f, 0.0f, -0.25f) * scale;
    return c;
}

float distance(const scene::Camera& c) { return glm::length(c.position - c.target); }

} // namespace

TEST(CameraControl, OrbitKeepsTheTargetAndDistanceAndStopsShortOfThePoles)
{
    for (const float scale : {1e-3f, 1.0f, 1e5f}) {
        SCOPED_TRACE(scale);
        const scene::Camera c = cameraAt(scale);
        const scene::Camera o = orbit(c, 37.0f, 12.0f);
        EXPECT_EQ(o.target, c.target);
        EXPECT_NEAR(distance(o), distance(c), distance(c) * 1e-5f);
        EXPECT_GT(glm::length(o.position - c.position), distance(c) * 0.1f);
        // A full turn of yaw comes back.
        const scene::Camera round = orbit(c, 360.0f, 0.0f);
        EXPECT_NEAR(glm::length(round.position - c.position), 0.0f, distance(c) * 1e-4f);
        // Pitching far past the pole stops 1 degree short: the view never flips.
        const scene::Camera top = orbit(c, 0.0f, 500.0f);
        const glm::vec3 toEye = glm::normalize(top.position - top.target);
        EXPECT_NEAR(glm::degrees(std::asin(toEye.y)), 89.0f, 0.01f);
        const scene::Camera bottom = orbit(c, 0.0f, -500.0f);
        EXPECT_NEAR(glm::degrees(std::asin(glm::normalize(bottom.position - bottom.target).y)), -89.0f, 0.01f);
    }
}

TEST(CameraControl, PanMovesEyeAndTargetTogetherAndDollyStaysOutsideTheTarget)
{
    for (const float scale : {1e-3f, 1.0f, 1e5f}) {
        SCOPED_TRACE(scale);
        const scene::Camera c = cameraAt(scale);
        const scene::Camera p = pan(c, 0.1f, -0.05f);
        EXPECT_NEAR(glm::length((p.position - p.target) - (c.position - c.target)), 0.0f, distance(c) * 1e-5f);
        EXPECT_NEAR(glm::length(p.position - c.position), distance(c) * std::sqrt(0.01f + 0.0025f), distance(c) * 1e-4f);
        const scene::Camera closer = dolly(c, 0.5f, scale);
        EXPECT_NEAR(distance(closer), distance(c) * 0.5f, distance(c) * 1e-5f);
        // However often the wheel turns, the eye stays 1e-4 of the scene off the target.
        scene::Camera d = c;
        for (int i = 0; i < 1000; ++i) d = dolly(d, 0.5f, scale);
        EXPECT_NEAR(distance(d), scale * 1e-4f, scale * 1e-6f);
        EXPECT_TRUE(std::isfinite(d.position.x));
        // Bad factors change nothing.
        EXPECT_EQ(dolly(c, 0.0f, scale).position, c.position);
        EXPECT_EQ(dolly(c, NAN, scale).position, c.position);
    }
}

TEST(CameraControl, FlyMovesAlongTheViewAndFirstPersonStaysLevel)
{
    const scene::Camera c = cameraAt(1.0f);
    const glm::vec3 view = glm::normalize(c.target - c.position);
    const scene::Camera f = fly(c, 0.0f, 0.0f, glm::vec3(0.0f, 0.0f, 2.0f));
    EXPECT_NEAR(glm::length(f.position - (c.position + view * 2.0f)), 0.0f, 1e-5f);
    EXPECT_NEAR(glm::length((f.target - f.position) - (c.target - c.position)), 0.0f, 1e-5f);
    const scene::Camera level = fly(c, 0.0f, 0.0f, glm::vec3(0.0f, 0.0f, 2.0f), true);
    EXPECT_NEAR(level.position.y, c.position.y, 1e-5f);  // looking down, yet walking on the level
    EXPECT_NEAR(glm::length(level.position - c.position), 2.0f, 1e-5f);
    // Looking around turns the view about the eye.
    const scene::Camera turned = fly(c, 90.0f, 0.0f, glm::vec3(0.0f));
    EXPECT_EQ(turned.position, c.position);
    EXPECT_NEAR(glm::dot(glm::normalize(turned.target - turned.position), view), view.y * view.y, 1e-4f);
    // Speed is relative to the scene, and bounded for a scene without size.
    EXPECT_FLOAT_EQ(flySpeed(1e5f, 0.0f), 1e4f);
    EXPECT_FLOAT_EQ(flySpeed(1e-3f, 1.0f), 2e-4f);
    EXPECT_FLOAT_EQ(flySpeed(0.0f, 0.0f), 0.1f);
    EXPECT_FLOAT_EQ(flySpeed(NAN, 100.0f), 0.1f * std::exp2(20.0f));
}

TEST(ViewerScript, WordsQuotesCommentsAndWhereEachCommandCameFrom)
{
    const std::vector<ScriptCommand> s =
        parseScript("open \"my scene.json\"  # a comment\n\n  set hard.pcf_kernel=5\r\nscreenshot a#b.png\n", "s.txt", false);
    ASSERT_EQ(s.size(), 3u);
    EXPECT_EQ(s[0].words, (std::vector<std::string>{"open", "my scene.json"}));
    EXPECT_EQ(s[0].where, "s.txt:1");
    EXPECT_EQ(s[1].words, (std::vector<std::string>{"set", "hard.pcf_kernel=5"}));
    EXPECT_EQ(s[1].where, "s.txt:3");
    EXPECT_EQ(s[2].words, (std::vector<std::string>{"screenshot", "a#b.png"}));  // '#' inside a word is the word's

    const std::vector<ScriptCommand> e = parseScript("frames 2; orbit 10 5 ;; quit", "--exec", true);
    ASSERT_EQ(e.size(), 3u);
    EXPECT_EQ(e[1].words, (std::vector<std::string>{"orbit", "10", "5"}));
    EXPECT_EQ(e[1].where, "--exec 2");
    EXPECT_EQ(e[2].where, "--exec 3");

    try {
        parseScript("frames 1\nopen \"unclosed\n", "s.txt", false);
        FAIL() << "an unclosed quote was accepted";
    } catch (const Error& err) {
        EXPECT_NE(std::string(err.what()).find("s.txt:2"), std::string::npos) << err.what();
    }
    EXPECT_THROW(readScript("/no/such/script.txt"), Error);
}

TEST(ShaderWatcher, SeesEditsAdditionsAndRemovalsOfShadersOnlyOnce)
{
    namespace fs = std::filesystem;
    const fs::path dir = fs::temp_directory_path() / ("penumbra_watch_" + std::to_string(::getpid()));
    fs::create_directories(dir / "sub");
    std::ofstream(dir / "a.comp") << "void main() {}";
    std::ofstream(dir / "notes.txt") << "not a shader";
    ShaderWatcher watcher;
    watcher.watch({dir, dir / "missing-folder"});
    const auto now = std::chrono::milliseconds(0);
    EXPECT_FALSE(watcher.changed(now));
    std::ofstream(dir / "notes.txt") << "edited, but not a shader";
    EXPECT_FALSE(watcher.changed(now));
    std::ofstream(dir / "sub" / "b.glsl") << "float f();";
    EXPECT_TRUE(watcher.changed(now));
    EXPECT_EQ(watcher.lastChanged(), (std::vector<std::string>{(dir / "sub" / "b.glsl").string()}));
    EXPECT_FALSE(watcher.changed(now));  // once per change
    std::ofstream(dir / "a.comp", std::ios::app) << "\n// longer";
    EXPECT_TRUE(watcher.changed(now));
    fs::remove(dir / "sub" / "b.glsl");
    EXPECT_TRUE(watcher.changed(now));
    EXPECT_EQ(watcher.lastChanged(), (std::vector<std::string>{(dir / "sub" / "b.glsl").string()}));
    // Polled at most every interval.
    std::ofstream(dir / "c.frag") << "void main() {}";
    EXPECT_FALSE(watcher.changed(std::chrono::hours(1)));
    fs::remove_all(dir);
}
