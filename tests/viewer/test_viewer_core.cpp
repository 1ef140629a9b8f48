// The viewer's parts that need no window (apps/penumbra-viewer/): camera moves
// (CameraControl.h) at scene scales from 1e-3 to 1e5 and camera tracks left out, script
// parsing (Script.h) and its command table (CommandTable.h), the A/B comparison's state
// with a drawer that answers at once (Comparison.h), shader watching (ShaderWatcher.h)
// and the panels' layer geometry (PanelLayer.h) on Dear ImGui's own draw data.
#include "ScratchFolder.h"  // support/

#include "CameraControl.h"
#include "CommandTable.h"
#include "Comparison.h"
#include "PanelLayer.h"
#include "Script.h"
#include "ShaderWatcher.h"

#include "penumbra/core/Error.h"
#include "penumbra/metrics/DebugImage.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sys/stat.h>
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

TEST(CameraControl, AFreeCameraLeavesOutTheCameraTracksOnly)
{
    config::RenderConfig c;
    c.animation.tracks = {{"/camera/position", config::Interpolation::Linear, {{0.0f, {1, 2, 3}}}},
                          {"/lights/0/intensity", config::Interpolation::Linear, {{0.0f, {5}}}},
                          {"/camera/fov_y_deg", config::Interpolation::Step, {{0.0f, {30}}}}};
    EXPECT_TRUE(hasCameraTrack(c.animation));
    const config::RenderConfig free = withoutCameraTracks(c);
    ASSERT_EQ(free.animation.tracks.size(), 1u);
    EXPECT_EQ(free.animation.tracks[0].target, "/lights/0/intensity");
    EXPECT_FALSE(hasCameraTrack(free.animation));
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
    // A FIFO as the script is named, never waited on.
    const std::filesystem::path fifo = std::filesystem::temp_directory_path() / ("penumbra_script_" + std::to_string(::getpid()));
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    try {
        readScript(fifo);
        ADD_FAILURE() << "a FIFO was read as a script";
    } catch (const Error& err) {
        EXPECT_NE(std::string(err.what()).find(": is a FIFO (named pipe), expected a viewer script"), std::string::npos)
            << err.what();
    }
    std::filesystem::remove(fifo);
}

namespace {

// What a table's handlers act on in these tests.
struct Recorder {
    std::vector<std::string> ran;
};

const CommandTable<Recorder>& recorderCommands()
{
    static const CommandTable<Recorder> table{
        {{"orbit", {"YAW PITCH"}, "turns the camera"}, [](Recorder& r, const ScriptCommand& c) { r.ran.push_back(c.words[0]); }},
        {{"show", {"IMAGE [linear|log]", "color"}, "shows an image"},
         [](Recorder& r, const ScriptCommand& c) { r.ran.push_back(c.words[0] + std::to_string(c.words.size() - 1)); }},
        {{"quit", {}, "closes the window"}, [](Recorder& r, const ScriptCommand& c) { r.ran.push_back(c.words[0]); }},
    };
    return table;
}

std::string errorOf(const CommandTable<Recorder>& table, const std::string& text)
{
    Recorder r;
    try {
        table.run(r, parseScript(text, "--exec", true).at(0));
    } catch (const Error& e) {
        EXPECT_TRUE(r.ran.empty()) << "a handler ran for a command the table refused: " << text;
        return e.what();
    }
    return {};
}

} // namespace

TEST(ViewerCommands, TheTableDispatchesChecksArgumentCountsAndNamesEveryVerb)
{
    const CommandTable<Recorder>& table = recorderCommands();
    Recorder r;
    for (const ScriptCommand& c : parseScript("orbit 10 5; show shadow.depth; show shadow.depth log; show color; quit", "--exec", true)) {
        table.run(r, c);
    }
    EXPECT_EQ(r.ran, (std::vector<std::string>{"orbit", "show1", "show2", "show1", "quit"}));

    // An unknown verb: where, the verb, every verb, and the closest within two edits.
    EXPECT_EQ(errorOf(table, "orbitt 10 5"),
              "--exec 1: unknown command \"orbitt\" (did you mean \"orbit\"?); the commands are orbit, show, quit");
    EXPECT_EQ(errorOf(table, "fly away"), "--exec 1: unknown command \"fly\"; the commands are orbit, show, quit");
    // A count no form takes: the verb and its forms.
    EXPECT_EQ(errorOf(table, "orbit 10"), "--exec 1: orbit: expected `orbit YAW PITCH`, got 1 argument");
    EXPECT_EQ(errorOf(table, "show a b c"),
              "--exec 1: show: expected `show IMAGE [linear|log]` or `show color`, got 3 arguments");
    EXPECT_EQ(errorOf(table, "quit now"), "--exec 1: quit: expected `quit` with no arguments, got 1 argument");

    // A verb twice is the table's own mistake.
    EXPECT_THROW(CommandList({{"quit", {}, "a"}, {"quit", {}, "b"}}), Error);
}

TEST(ViewerCommands, TheMarkdownListHasARowPerVerbWithItsFormsAndPipesEscaped)
{
    EXPECT_EQ(recorderCommands().list().markdown(), "| command | what it does |\n"
                                                    "|---|---|\n"
                                                    "| `orbit YAW PITCH` | turns the camera |\n"
                                                    "| `show IMAGE [linear\\|log]`, `show color` | shows an image |\n"
                                                    "| `quit` | closes the window |\n");
}

namespace {

// B's drawer as the comparison sees it, answering when the test says: what it was asked.
struct DrawerLog {
    std::vector<std::vector<std::filesystem::path>> made;  // the search path of each drawer made
    std::vector<ComparisonRequest> requests;
    size_t cancels = 0;
    std::optional<ComparisonResult> finished;
};

class FakeDrawer final : public BDrawer {
public:
    explicit FakeDrawer(DrawerLog& log) : log_(log) {}
    void request(ComparisonRequest request) override { log_.requests.push_back(std::move(request)); }
    void cancel() override { ++log_.cancels; }
    DrawerProgress progress() const override { return {}; }
    std::optional<ComparisonResult> take() override { return std::exchange(log_.finished, std::nullopt); }
    uint32_t validationMessages() const override { return 1; }

private:
    DrawerLog& log_;
};

Comparison::MakeDrawer fakeDrawers(DrawerLog& log)
{
    return [&log](const std::vector<std::filesystem::path>& searchPath) {
        log.made.push_back(searchPath);
        return std::make_unique<FakeDrawer>(log);
    };
}

// A 2 x 1 view of geometry under one directional light.
config::RenderConfig twoPixelView()
{
    config::RenderConfig c;
    c.width = 2;
    c.height = 1;
    c.lights.resize(1);
    c.lights[0].name = "sun";
    c.lights[0].light.type = scene::LightType::Directional;
    return c;
}

// B's frame for `key`: every pixel geometry, V as given.
ComparisonResult bFrame(const std::string& key, std::vector<float> visibility)
{
    ComparisonResult r;
    r.viewKey = key;
    r.images.width = uint32_t(visibility.size());
    r.images.height = 1;
    r.images.color.assign(4 * visibility.size(), 128);
    r.images.positions.assign(4 * visibility.size(), 1.0f);  // w = 1: geometry
    r.images.visibility = {std::move(visibility)};
    return r;
}

using namespace std::chrono_literals;
using ReadA = std::function<std::vector<std::vector<float>>()>;

// The view rests from t0 on, B is asked for and answers with V = `bVisibility`.
void restAndDrawB(Comparison& comparison, DrawerLog& log, const config::RenderConfig& view, const ReadA& readA,
                  std::vector<float> bVisibility, Comparison::Clock::time_point t0)
{
    comparison.update(view, 0.0f, t0, readA);
    comparison.update(view, 0.0f, t0 + 1s, readA);
    ASSERT_FALSE(log.requests.empty());
    log.finished = bFrame(log.requests.back().viewKey, std::move(bVisibility));
    comparison.update(view, 0.0f, t0 + 2s, readA);
}

} // namespace

TEST(Comparison, BIsAskedForOnceTheViewRestsAndShownOnlyForTheViewItWasDrawnFor)
{
    DrawerLog log;
    Comparison comparison(fakeDrawers(log));
    EXPECT_FALSE(comparison.on());
    comparison.start("hard", 1, {"/plugins"});
    ASSERT_EQ(log.made.size(), 1u);
    EXPECT_EQ(log.made[0], (std::vector<std::filesystem::path>{"/plugins"}));

    const config::RenderConfig view = twoPixelView();
    int aReads = 0;
    const auto readA = [&] {
        ++aReads;
        return std::vector<std::vector<float>>{{1.0f, 0.5f}};
    };
    const auto t0 = Comparison::Clock::now();
    comparison.update(view, 0.0f, t0, readA);
    comparison.update(view, 0.0f, t0 + Comparison::kRestBeforeRequest - 1ms, readA);
    EXPECT_TRUE(log.requests.empty()) << "B was asked for before the view rested";
    comparison.update(view, 0.0f, t0 + Comparison::kRestBeforeRequest, readA);
    comparison.update(view, 0.0f, t0 + 2s, readA);
    ASSERT_EQ(log.requests.size(), 1u) << "one request per view";
    const ComparisonRequest& asked = log.requests[0];
    EXPECT_EQ(asked.viewKey, viewKey(view, 0.0f));
    ASSERT_EQ(asked.config.lights.size(), 1u);
    EXPECT_EQ(asked.config.lights[0].shadow.technique, "hard");
    EXPECT_EQ(asked.config.lights[0].shadow.required, true);  // a B that cannot run is an error, not unshadowed
    EXPECT_FALSE(comparison.current());

    // B's image: A's error against it, read once, as compare computes it.
    log.finished = bFrame(asked.viewKey, {0.5f, 0.5f});
    const uint64_t versionBefore = comparison.bImageVersion();
    comparison.update(view, 0.0f, t0 + 3s, readA);
    ASSERT_TRUE(comparison.current());
    EXPECT_TRUE(comparison.ready());
    EXPECT_NE(comparison.bImageVersion(), versionBefore);
    ASSERT_EQ(comparison.errors().size(), 1u);
    EXPECT_EQ(comparison.errors()[0].all.pixels, 2u);
    EXPECT_NEAR(comparison.errors()[0].all.maxAbsError, 0.5, 1e-6);
    EXPECT_NEAR(comparison.errors()[0].all.rmse, std::sqrt(0.125), 1e-6);
    comparison.update(view, 0.0f, t0 + 4s, readA);
    EXPECT_EQ(aReads, 1) << "A's V is read only when A or B changed";
    comparison.aChanged();
    EXPECT_FALSE(comparison.ready());
    comparison.update(view, 0.0f, t0 + 5s, readA);
    EXPECT_EQ(aReads, 2);

    comparison.setView(CompareView::B);
    EXPECT_TRUE(comparison.replacesA());
    EXPECT_TRUE(comparison.shows(CompareView::B));

    // The view moves: B is of the old view, not shown, and asked for again once it rests.
    config::RenderConfig moved = view;
    moved.camera.position.x += 1.0f;
    comparison.update(moved, 0.0f, t0 + 6s, readA);
    EXPECT_FALSE(comparison.current());
    EXPECT_FALSE(comparison.replacesA()) << "B of another view replaced A";
    EXPECT_EQ(comparison.result(), nullptr);
    EXPECT_EQ(log.requests.size(), 1u);
    // A late result for the old view is not shown either.
    log.finished = bFrame(asked.viewKey, {0.0f, 0.0f});
    comparison.update(moved, 0.0f, t0 + 6s + Comparison::kRestBeforeRequest, readA);
    EXPECT_FALSE(comparison.current());
    ASSERT_EQ(log.requests.size(), 2u);
    EXPECT_EQ(log.requests[1].viewKey, viewKey(moved, 0.0f));

    // B fails for this view: said once, and kept for wait-compare.
    log.finished = ComparisonResult{log.requests[1].viewKey, {}, 0.0, "the reference ran out of memory"};
    EXPECT_EQ(comparison.update(moved, 0.0f, t0 + 8s, readA), "B: the reference ran out of memory");
    EXPECT_EQ(comparison.bError(), "the reference ran out of memory");
    EXPECT_FALSE(comparison.ready());

    comparison.stop();
    EXPECT_FALSE(comparison.on());
    EXPECT_FALSE(comparison.replacesA());
}

TEST(Comparison, ChangedSettingsCancelAndPluginReloadsAskForBAgain)
{
    DrawerLog log;
    Comparison comparison(fakeDrawers(log));
    comparison.start("reference", 1, {"/plugins"});
    const nlohmann::json* samples = comparison.bShadows().at(0).param("samples");
    ASSERT_NE(samples, nullptr);
    EXPECT_EQ(*samples, 16) << "B's reference starts at 16 rays a pixel";
    const config::RenderConfig view = twoPixelView();
    const ReadA readA = [] { return std::vector<std::vector<float>>{{1.0f, 1.0f}}; };
    const auto t0 = Comparison::Clock::now();
    restAndDrawB(comparison, log, view, readA, {1.0f, 1.0f}, t0);
    ASSERT_EQ(log.requests.size(), 1u);
    ASSERT_TRUE(comparison.current());

    // An edit of B's settings: the frame in flight is cancelled and B asked for at once
    // (the view has rested already), with the new settings.
    const size_t cancels = log.cancels;
    comparison.bShadows()[0].technique = "pcss";
    comparison.settingsChanged();
    EXPECT_GT(log.cancels, cancels);
    EXPECT_FALSE(comparison.current());
    comparison.update(view, 0.0f, t0 + 2s, readA);
    ASSERT_EQ(log.requests.size(), 2u);
    EXPECT_EQ(log.requests[1].config.lights[0].shadow.technique, "pcss");

    // Cancel: not asked again until the view or B changes.
    comparison.cancel();
    comparison.update(view, 0.0f, t0 + 5s, readA);
    EXPECT_EQ(log.requests.size(), 2u);

    // A plugin reload: a new drawer with the fresh copies, B's settings kept, B asked for anew.
    EXPECT_TRUE(comparison.usePlugins({"/fresh"}));
    ASSERT_EQ(log.made.size(), 2u);
    EXPECT_EQ(log.made[1], (std::vector<std::filesystem::path>{"/fresh"}));
    EXPECT_EQ(comparison.validationMessages(), 2u) << "the replaced drawer's messages count too";
    comparison.update(view, 0.0f, t0 + 6s, readA);
    comparison.update(view, 0.0f, t0 + 6s + Comparison::kRestBeforeRequest, readA);
    ASSERT_EQ(log.requests.size(), 3u);
    EXPECT_EQ(log.requests[2].config.lights[0].shadow.technique, "pcss");

    // A light added: B draws it too, with B's technique.
    config::RenderConfig twoLights = view;
    twoLights.lights.push_back(view.lights[0]);
    twoLights.lights[1].name = "fill";
    comparison.update(twoLights, 0.0f, t0 + 7s, readA);
    ASSERT_EQ(comparison.bShadows().size(), 2u);
    EXPECT_EQ(comparison.bShadows()[1].technique, "pcss");
}

TEST(Comparison, TheDifferenceImageIsAbsoluteDVInFalseColourOverItsScale)
{
    DrawerLog log;
    Comparison comparison(fakeDrawers(log));
    comparison.start("hard", 1, {});
    const config::RenderConfig view = twoPixelView();
    restAndDrawB(comparison, log, view, [] { return std::vector<std::vector<float>>{{1.0f, 0.25f}}; }, {0.5f, 0.25f},
                 Comparison::Clock::now());
    ASSERT_TRUE(comparison.current());

    // The false-colour ramp's ends: |dV| at the scale and 0.
    const auto ramp = [](float value) {
        metrics::DebugImageValues one;
        one.width = one.height = 1;
        one.values = {value};
        return metrics::debugImageRgba(one, metrics::DebugMapping::FalseColor, {0.0, 1.0});
    };
    const uint64_t before = comparison.differenceVersion();
    comparison.setDifference(0, 0.5f);
    EXPECT_NE(comparison.differenceVersion(), before);
    std::vector<uint8_t> expected = ramp(1.0f);
    const std::vector<uint8_t> zero = ramp(0.0f);
    expected.insert(expected.end(), zero.begin(), zero.end());
    EXPECT_EQ(comparison.differenceRgba(), expected);
    // Twice the scale: |dV| = 0.5 sits in the middle of the ramp.
    comparison.setDifference(0, 1.0f);
    const std::vector<uint8_t> middle = ramp(0.5f);
    EXPECT_TRUE(std::equal(middle.begin(), middle.end(), comparison.differenceRgba().begin()));

    EXPECT_EQ(parseCompareView("split"), CompareView::Split);
    EXPECT_EQ(parseCompareView("B"), std::nullopt);
}

TEST(ShaderWatcher, SeesEditsAdditionsAndRemovalsOfShadersOnlyOnce)
{
    namespace fs = std::filesystem;
    const penumbra::test::ScratchFolder scratch("watch");
    const fs::path& dir = scratch.path;
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
}

namespace {

// A Dear ImGui frame without a window or a device: a side panel like the viewer's (no
// border, `panelWidth` wide, the display's height), then, when `tooltipAt` is set, a
// tooltip there. The font atlas is built on the CPU.
class ImGuiFrame {
public:
    ImGuiFrame(float width, float height, float panelWidth, std::optional<ImVec2> tooltipAt, float framebufferScale = 1.0f)
    {
        context_ = ImGui::CreateContext();
        ImGuiIO& io = ImGui::GetIO();
        io.IniFilename = nullptr;
        io.DisplaySize = ImVec2(width, height);
        io.DisplayFramebufferScale = ImVec2(framebufferScale, framebufferScale);
        io.DeltaTime = 1.0f / 60.0f;
        unsigned char* pixels = nullptr;
        int w = 0, h = 0;
        io.Fonts->GetTexDataAsRGBA32(&pixels, &w, &h);
        io.MousePos = tooltipAt ? *tooltipAt : ImVec2(-1.0f, -1.0f);
        // Twice: a window that sizes itself (the tooltip) is hidden in its first frame.
        for (int frame = 0; frame < 2; ++frame) {
            ImGui::NewFrame();
            ImGui::SetNextWindowPos(ImVec2(0, 0));
            ImGui::SetNextWindowSize(ImVec2(panelWidth, height));
            ImGui::PushStyleVar(ImGuiStyleVar_WindowBorderSize, 0.0f);
            ImGui::Begin("panel", nullptr, ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize);
            ImGui::PopStyleVar();
            for (int i = 0; i < 60; ++i) ImGui::Text("line %d of a panel long enough to scroll", i);
            ImGui::End();
            if (tooltipAt) ImGui::SetTooltip("pixel (%d, %d)", int(tooltipAt->x), int(tooltipAt->y));
            ImGui::Render();
        }
    }
    ~ImGuiFrame() { ImGui::DestroyContext(context_); }
    ImGuiFrame(const ImGuiFrame&) = delete;
    ImGuiFrame& operator=(const ImGuiFrame&) = delete;
    const ImDrawData& data() const { return *ImGui::GetDrawData(); }

private:
    ImGuiContext* context_ = nullptr;
};

VkRect2D rect(int32_t x, int32_t y, uint32_t w, uint32_t h) { return {{x, y}, {w, h}}; }

} // namespace

TEST(PanelLayer, ThePanelBesideTheViewGoesIntoTheLayerAndATooltipOverItIsDrawnOverTheFrame)
{
    for (const float scale : {1.0f, 2.0f}) {  // HiDPI: framebuffer pixels are `scale` points
        SCOPED_TRACE(scale);
        const VkExtent2D extent{uint32_t(1200 * scale), uint32_t(600 * scale)};
        const VkRect2D view = rect(int32_t(440 * scale), 0, uint32_t(760 * scale), uint32_t(600 * scale));
        {
            const ImGuiFrame frame(1200, 600, 440, std::nullopt, scale);
            ASSERT_EQ(frame.data().CmdListsCount, 1);
            const VkRect2D panel = drawnArea(frame.data(), extent);
            EXPECT_EQ(panel.offset.x, 0);
            EXPECT_EQ(panel.offset.y, 0);
            EXPECT_LE(panel.extent.width, uint32_t(440 * scale));  // not a pixel into the view
            EXPECT_GT(panel.extent.width, uint32_t(400 * scale));
            EXPECT_EQ(listsInLayer(frame.data(), view, extent), 1u);
            EXPECT_EQ(listsInLayer(frame.data(), std::nullopt, extent), 1u);
        }
        {
            const ImGuiFrame frame(1200, 600, 440, ImVec2(900, 300), scale);
            ASSERT_EQ(frame.data().CmdListsCount, 2);
            const VkRect2D tooltip = drawnArea(frame.data(), {frame.data().CmdLists[1]}, extent);
            EXPECT_TRUE(intersects(tooltip, view));
            EXPECT_GE(tooltip.offset.x, int32_t(900 * scale));  // where it is, not the display's clip rectangle
            EXPECT_LT(tooltip.extent.width, uint32_t(400 * scale));
            EXPECT_EQ(listsInLayer(frame.data(), view, extent), 1u);
            // A panel wider than the band: it reaches into the view, and so does everything after it.
            EXPECT_EQ(listsInLayer(frame.data(), rect(int32_t(300 * scale), 0, 900, 600), extent), 0u);
            const std::vector<ImDrawList*> over{frame.data().CmdLists[1]};
            const ImDrawData part = subset(frame.data(), over);
            EXPECT_EQ(part.CmdListsCount, 1);
            EXPECT_EQ(part.TotalVtxCount, frame.data().CmdLists[1]->VtxBuffer.Size);
            EXPECT_EQ(part.TotalIdxCount, frame.data().CmdLists[1]->IdxBuffer.Size);
            EXPECT_EQ(part.DisplaySize.x, frame.data().DisplaySize.x);
        }
    }
}

TEST(PanelLayer, RectangleTestsShareOnlyPixelsBothCover)
{
    EXPECT_TRUE(intersects(rect(0, 0, 10, 10), rect(9, 9, 5, 5)));
    EXPECT_FALSE(intersects(rect(0, 0, 10, 10), rect(10, 0, 5, 5)));  // touching edges share no pixel
    EXPECT_FALSE(intersects(rect(0, 0, 0, 10), rect(0, 0, 5, 5)));    // empty
    const VkRect2D b = boundingRect(rect(-2, 3, 4, 4), rect(5, 0, 1, 1));
    EXPECT_EQ(b.offset.x, -2);
    EXPECT_EQ(b.offset.y, 0);
    EXPECT_EQ(b.extent.width, 8u);
    EXPECT_EQ(b.extent.height, 7u);
    EXPECT_TRUE(sameRects({rect(1, 2, 3, 4)}, {rect(1, 2, 3, 4)}));
    EXPECT_FALSE(sameRects({rect(1, 2, 3, 4)}, {rect(1, 2, 3, 5)}));
    EXPECT_FALSE(sameRects({rect(1, 2, 3, 4)}, {}));
}
