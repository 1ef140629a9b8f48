// `penumbra-viewer` as a script drives it under Xvfb (xvfb-run): what it shows, what it
// saves, and how it fails. The frame must be `penumbra render`'s frame of the saved config.
#include "ExrFile.h"        // support/
#include "ScratchFolder.h"  // support/
#include "TestPaths.h"      // support/: the build tree's paths

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#define STB_IMAGE_IMPLEMENTATION
#include <stb/stb_image.h>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <thread>

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

struct RunResult {
    int exitCode = -1;
    std::string out, err;
};

std::string slurp(const fs::path& p)
{
    std::ifstream in(p, std::ios::binary);
    std::ostringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

struct Png {
    int width = 0, height = 0;
    std::vector<uint8_t> rgba;
};

Png readPng(const fs::path& path)
{
    Png png;
    int channels = 0;
    stbi_uc* data = stbi_load(path.c_str(), &png.width, &png.height, &channels, 4);
    if (!data) {
        ADD_FAILURE() << "cannot read " << path;
        return png;
    }
    png.rgba.assign(data, data + size_t(png.width) * png.height * 4);
    stbi_image_free(data);
    return png;
}

// xvfb-run with a screen large enough for the default window (a 1280 x 720 frame and the
// panel). `-a` takes the first free display from `-n` on; each test process starts its
// search at its own number, so that two tests run side by side (ctest -j) do not race for
// the same display.
std::string xvfb()
{
    return fmt::format("xvfb-run -a -n {} -s '-screen 0 1920x1080x24'", 100 + ::getpid() % 5000 * 4);
}

class ViewerTest : public penumbra::test::ScratchFolderTest {
protected:
    // Runs `prefix penumbra-viewer FILE --validation --no-vsync --exec SCRIPT` (the
    // script's commands separated by ';').
    RunResult viewer(const std::string& file, const std::string& script, const std::string& prefix = xvfb()) const
    {
        const std::string command = fmt::format("{} '{}' '{}' --validation --no-vsync --exec '{}'", prefix,
                                                penumbra::test::viewerExecutable().string(), file, script);
        RunResult r = run(command);
        // xvfb-run exits 5, hiding the viewer's own status, when it cannot remove its
        // temporary folder (seen once in a ctest -j2 run, with the viewer done): that is
        // the wrapper's failure, not the viewer's, so the run is made once more.
        if (r.exitCode == 5 && r.err.find("xvfb-run: error: problem while cleaning up temporary directory") != std::string::npos)
            r = run(command);
        return r;
    }

    RunResult render(const std::string& args) const
    {
        return run(fmt::format("'{}' render {}", penumbra::test::penumbraExecutable().string(), args));
    }

    // A shell command with its output captured.
    RunResult run(const std::string& command) const
    {
        const fs::path out = dir / "stdout.txt", err = dir / "stderr.txt";
        const int status = std::system(fmt::format("{} > '{}' 2> '{}' < /dev/null", command, out.string(), err.string()).c_str());
        RunResult r;
        r.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
        r.out = slurp(out);
        r.err = slurp(err);
        return r;
    }

    std::string config(const std::string& name) const { return (penumbra::test::sourceDir() / "config" / name).string(); }

    struct ScriptError {
        std::string script, expected;  // the script, and a part of its error message
    };
    // Each script, run on config/default.json, ends with exit 1 and its message (a `quit`
    // after it: a script that does not fail ends too).
    void expectScriptErrors(const std::vector<ScriptError>& cases, const std::string& prefix = xvfb()) const
    {
        for (const ScriptError& bad : cases) {
            SCOPED_TRACE(bad.script);
            const RunResult v = viewer(config("default.json"), bad.script + "; quit", prefix);
            EXPECT_EQ(v.exitCode, 1) << v.err;
            EXPECT_NE(v.err.find(bad.expected), std::string::npos) << v.err;
        }
    }
};

// A session's edits, then the screenshot, V and the saved config; `penumbra render` of the
// saved config must draw the same frame.
struct EditCase {
    std::string name;
    std::string file;   // relative to the source tree
    std::string edits;  // viewer commands
};

class ViewerEdits : public ViewerTest, public ::testing::WithParamInterface<EditCase> {};

} // namespace

TEST_P(ViewerEdits, TheSavedConfigRendersTheFrameTheViewerShowed)
{
    const EditCase& c = GetParam();
    const fs::path shot = dir / "viewer.png", exr = dir / "viewer.exr", saved = dir / "saved.json";
    const std::string script = fmt::format("size 200 120; {}; frames 2; screenshot {}; save-visibility {}; save {}; quit", c.edits,
                                           shot.string(), exr.string(), saved.string());
    const RunResult v = viewer((penumbra::test::sourceDir() / c.file).string(), script);
    ASSERT_EQ(v.exitCode, 0) << v.err;

    const fs::path cliShot = dir / "cli.png", cliExr = dir / "cli.exr";
    const RunResult r = render(fmt::format("'{}' -o '{}' --visibility-exr '{}'", saved.string(), cliShot.string(), cliExr.string()));
    ASSERT_EQ(r.exitCode, 0) << r.err;

    const Png a = readPng(shot), b = readPng(cliShot);
    ASSERT_EQ(a.width, 200);
    ASSERT_EQ(a.height, 120);
    ASSERT_EQ(b.width, a.width);
    ASSERT_EQ(b.height, a.height);
    // The same renderer on the same config: the same bytes (one step of 8 bits allowed
    // where a technique's map was drawn from a moved camera's culling history).
    int differing = 0, worst = 0;
    for (size_t i = 0; i < a.rgba.size(); ++i) {
        const int d = std::abs(int(a.rgba[i]) - int(b.rgba[i]));
        worst = std::max(worst, d);
        differing += d > 0;
    }
    EXPECT_LE(worst, 1) << differing << " bytes differ";

    const penumbra::test::Exr va = penumbra::test::readExr(exr), vb = penumbra::test::readExr(cliExr);
    ASSERT_EQ(va.channels.size(), vb.channels.size());
    for (const auto& [channel, values] : va.channels) {
        ASSERT_TRUE(vb.channels.count(channel)) << channel;
        const std::vector<float>& other = vb.channels.at(channel);
        ASSERT_EQ(values.size(), other.size());
        float maxDiff = 0.0f;
        for (size_t i = 0; i < values.size(); ++i) maxDiff = std::max(maxDiff, std::abs(values[i] - other[i]));
        EXPECT_LE(maxDiff, 1e-3f) << channel;
    }
}

INSTANTIATE_TEST_SUITE_P(
    Configs, ViewerEdits,
    ::testing::Values(
        EditCase{"DefaultOrbitedWithPcss", "config/default.json",
                 "technique 0 pcss; set pcss.light_size=1.25; orbit 25 8; dolly 0.8"},
        EditCase{"TwoSpotsCulledAndMoved", "config/two-spots.json",
                 "culling frustum; light 1 intensity 450; light 0 position -6 14 5; param 1 pcf_kernel 5"},
        EditCase{"VsmFromAbove", "config/vsm.json", "orbit -40 30; camera 0 30 0.5 0 0 0"},
        EditCase{"GltfWithItsDefaultSun", "tests/data/gltf/quad.glb", "orbit 15 5; technique sun pcss"}),
    [](const ::testing::TestParamInfo<EditCase>& info) { return info.param.name; });

TEST_F(ViewerTest, EveryReflectedParameterOfEveryPluginGetsAWidget)
{
    // The plugins as `penumbra plugins --json` lists them, with their parameters.
    const fs::path list = dir / "plugins.json";
    ASSERT_EQ(std::system(fmt::format("'{}' plugins --json > '{}' 2> /dev/null", penumbra::test::penumbraExecutable().string(),
                                      list.string())
                              .c_str()),
              0);
    const json plugins = json::parse(slurp(list))["plugins"];
    ASSERT_GE(plugins.size(), 5u);
    std::string script = "size 64 36";
    std::set<std::string> expected;
    for (const json& p : plugins) {
        const std::string name = p["name"];
        // The reference traces rays: at its cheapest, so that the frame stays small.
        script += fmt::format("; technique 0 {}; {}frames 2; widgets", name,
                              name == "reference" ? "set reference.samples=1; " : "");
        for (const json& param : p["params"]) {
            expected.insert(fmt::format("light0 {} {} {}", name, param["name"].get<std::string>(), param["type"].get<std::string>()));
        }
    }
    const RunResult v = viewer(config("default.json"), script + "; quit");
    ASSERT_EQ(v.exitCode, 0) << v.err;
    std::set<std::string> drawn;
    std::istringstream lines(v.out);
    int kernels = 0;
    for (std::string line; std::getline(lines, line);) {
        if (line.rfind("widget ", 0) != 0) continue;
        // "widget LIGHT TECHNIQUE PARAM TYPE[ LO..HI step S]"
        std::istringstream words(line.substr(7));
        std::string light, technique, param, type, range, stepWord;
        int step = 0;
        words >> light >> technique >> param >> type >> range >> stepWord >> step;
        drawn.insert(fmt::format("{} {} {} {}", light, technique, param, type));
        if (param == "pcf_kernel") {
            // Every plugin's kernel is odd-only (ParamSpec::odd): its widget offers odd values only.
            ++kernels;
            int lo = 0, hi = 0;
            ASSERT_EQ(std::sscanf(range.c_str(), "%d..%d", &lo, &hi), 2) << line;
            EXPECT_EQ(step, 2) << line;
            EXPECT_EQ(lo % 2, 1) << line;
            EXPECT_EQ(hi % 2, 1) << line;
        }
    }
    EXPECT_EQ(drawn, expected);
    EXPECT_GE(kernels, 3);  // hard, deep, adaptive-sm
}

TEST_F(ViewerTest, ADebugImageIsShownAtItsOwnSizeAndItsPassesRunOnlyWhileShown)
{
    const fs::path map = dir / "map.png", color = dir / "color.png";
    const RunResult v = viewer(config("default.json"),
                               fmt::format("size 160 90; set hard.resolution=256; show light0.hard.shadow_map false-color; frames 1; "
                                           "screenshot {}; show color; frames 1; screenshot {}; quit",
                                           map.string(), color.string()));
    ASSERT_EQ(v.exitCode, 0) << v.err;
    const Png m = readPng(map), c = readPng(color);
    EXPECT_EQ(m.width, 256);
    EXPECT_EQ(m.height, 256);
    EXPECT_EQ(c.width, 160);
    EXPECT_EQ(c.height, 90);
    // False colour: the map is not one flat colour.
    std::set<uint32_t> colours;
    for (size_t i = 0; i < m.rgba.size(); i += 4) colours.insert(m.rgba[i] | m.rgba[i + 1] << 8 | m.rgba[i + 2] << 16);
    EXPECT_GT(colours.size(), 10u);
}

TEST_F(ViewerTest, ScriptErrorsNameTheCommandAndEndTheRunWithExit1)
{
    expectScriptErrors({
        {"frames 1; set hard.pcf_kernel=999", "--exec 2"},
        {"frames 1; set hard.pcf_kernel=999", "pcf_kernel"},
        {"frames 1; set hard.no_such_param=1", "no_such_param"},
        {"technique 0 no-such-technique", "no-such-technique"},
        {"light lamp intensity 5", "no light \"lamp\""},
        {"orbit ten 5", "expected a finite number, got \"ten\""},
        {"camera 0 10 0 0 0 0", "parallel to the up axis"},
        {"size 0 10", "expected a whole number in [1, 16384]"},
        {"show no.such.image", "no.such.image"},
        {"save /no/such/folder/x.json", "/no/such/folder"},
        {"ui of", "ui: expected on or off, got \"of\""},
        {"panel-layer yes", "panel-layer: expected on or off, got \"yes\""},
        {"panel shadows open", "panel: \"shadows\": expected one of"},
        {"panel timings shut", "expected open or closed"},
        {"frames 1; screenshot view.bmp", "an image is written as .png or .jpg (.jpeg)"},
    });
}

// docs/viewer.md's command list is the table's (`--list-commands`), row for row.
TEST_F(ViewerTest, TheCommandListIsTheTablesOwn)
{
    const RunResult list = run(fmt::format("'{}' --list-commands", penumbra::test::viewerExecutable().string()));
    ASSERT_EQ(list.exitCode, 0) << list.err;
    ASSERT_NE(list.out.find("| `quit` |"), std::string::npos) << list.out;
    const std::string doc = slurp(penumbra::test::sourceDir() / "docs" / "viewer.md");
    const size_t start = doc.find("| command | what it does |");
    ASSERT_NE(start, std::string::npos) << "docs/viewer.md has no command table";
    const size_t end = doc.find("\n\n", start);
    EXPECT_EQ(doc.substr(start, end - start + 1), list.out)
        << "docs/viewer.md's command table differs from the viewer's: paste `penumbra-viewer --list-commands`";
}

// Every command's verb and argument count are checked before the window opens: these fail
// without a display, naming the command (the window would have said "cannot open a window").
TEST_F(ViewerTest, AScriptIsCheckedAgainstTheTableBeforeTheWindowOpens)
{
    const std::string noDisplay = "env -u DISPLAY -u WAYLAND_DISPLAY";
    expectScriptErrors({{"frames 1; zoom in", "--exec 2: unknown command \"zoom\"; the commands are open, size,"},
                        {"frames 1; wait-compar", "unknown command \"wait-compar\" (did you mean \"wait-compare\"?)"},
                        {"orbit 10", "--exec 1: orbit: expected `orbit YAW PITCH`, got 1 argument"},
                        {"light sun intensity",
                         "expected `light LIGHT position|direction|target X Y Z` or `light LIGHT intensity V`"},
                        {"quit now", "quit: expected `quit` with no arguments"}},
                       noDisplay);
}

TEST_F(ViewerTest, WithoutADisplayItSaysSoAndExits1)
{
    const RunResult v = viewer(config("default.json"), "quit", "env -u DISPLAY -u WAYLAND_DISPLAY");
    EXPECT_EQ(v.exitCode, 1) << v.err;
    EXPECT_NE(v.err.find("cannot open a window"), std::string::npos) << v.err;
    EXPECT_EQ(v.err.find("Segmentation"), std::string::npos) << v.err;
}

TEST_F(ViewerTest, AFileThatDoesNotOpenIsNamed)
{
    const RunResult v = viewer("/no/such/scene.json", "quit");
    EXPECT_EQ(v.exitCode, 1) << v.err;
    EXPECT_NE(v.err.find("/no/such/scene.json"), std::string::npos) << v.err;
}

// Saving is all or nothing: a viewer killed (SIGKILL) at any moment while it saves over a
// config leaves the old file or the new one, whole.
TEST_F(ViewerTest, KilledWhileSavingLeavesAWholeConfig)
{
    const fs::path saved = dir / "saved.json";
    std::ofstream(saved) << slurp(config("default.json"));
    std::string script = "size 64 36; frames 1";
    for (int i = 0; i < 400; ++i) script += fmt::format("; orbit 1 0; save {}", saved.string());
    for (int round = 0; round < 4; ++round) {
        SCOPED_TRACE(round);
        const pid_t pid = fork();
        ASSERT_GE(pid, 0);
        if (pid == 0) {
            setpgid(0, 0);  // xvfb-run, Xvfb and the viewer: killed together below
            const std::string cmd = fmt::format("exec {} '{}' '{}' --no-vsync --exec '{}; quit' > /dev/null 2>&1", xvfb(),
                                                penumbra::test::viewerExecutable().string(), config("default.json"), script);
            execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
            _exit(127);
        }
        setpgid(pid, pid);
        // Once it is saving (the file changed), kill it at a moment that moves every round.
        const auto start = std::chrono::steady_clock::now();
        const std::string before = slurp(saved);
        while (slurp(saved) == before && std::chrono::steady_clock::now() - start < std::chrono::seconds(60)) {
            std::this_thread::sleep_for(std::chrono::milliseconds(5));
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(7 * round + 1));
        kill(-pid, SIGKILL);
        int status = 0;
        waitpid(pid, &status, 0);
        const json parsed = json::parse(slurp(saved), nullptr, false);
        ASSERT_FALSE(parsed.is_discarded()) << "a broken config after a kill";
        EXPECT_TRUE(parsed.contains("camera"));
    }
}

namespace {

// Starts the viewer in the background (its own process group, under xvfb-run) with
// `env` before it; returns its pid.
pid_t startViewer(const std::string& env, const std::string& file, const std::string& script, const fs::path& log)
{
    const pid_t pid = fork();
    if (pid == 0) {
        setpgid(0, 0);
        const std::string cmd = fmt::format("exec env {} {} '{}' '{}' --validation --no-vsync --exec '{}' > '{}' 2>&1", env, xvfb(),
                                            penumbra::test::viewerExecutable().string(), file, script, log.string());
        execl("/bin/sh", "sh", "-c", cmd.c_str(), static_cast<char*>(nullptr));
        _exit(127);
    }
    if (pid > 0) setpgid(pid, pid);
    return pid;
}

// A background viewer's process group (xvfb-run, Xvfb, the viewer), killed when the test
// leaves early; set pid to 0 once it was waited for.
struct ViewerGroup {
    pid_t pid;
    ~ViewerGroup()
    {
        if (pid > 0) kill(-pid, SIGKILL);  // kill(0, ...) would be this process group
    }
};

bool waitForFile(const fs::path& file, pid_t viewer)
{
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
    while (std::chrono::steady_clock::now() < deadline) {
        if (fs::exists(file)) {
            std::this_thread::sleep_for(std::chrono::milliseconds(100));  // written whole (PNG through a staged file)
            return true;
        }
        int status = 0;
        if (waitpid(viewer, &status, WNOHANG) == viewer) return false;  // it ended first
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return false;
}

void replaceInFile(const fs::path& file, const std::string& from, const std::string& to)
{
    std::string text = slurp(file);
    const size_t at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from << " not in " << file;
    text.replace(at, from.size(), to);
    std::ofstream(file, std::ios::trunc) << text;
}

} // namespace

// Hot reload: an edited shader takes effect without a restart; a broken one shows
// "path:line: error" and the last good frame stays on screen.
TEST_F(ViewerTest, AnEditedShaderIsReloadedAndABrokenOneKeepsTheLastFrame)
{
    const fs::path shaders = dir / "shaders";
    fs::copy(penumbra::test::sourceDir() / "shaders", shaders, fs::copy_options::recursive);
    const fs::path shading = shaders / "engine" / "shading.glsl";
    const std::string original = slurp(shading);
    const std::string store = "imageStore(outColor, pixel, vec4(display, 1.0));";
    ASSERT_NE(original.find(store), std::string::npos) << "shading.glsl no longer stores `display`: update this test";

    const fs::path a = dir / "a.png", b = dir / "b.png", c = dir / "c.png", log = dir / "viewer.log";
    const std::string script = fmt::format(
        "size 96 54; frames 2; screenshot {}; wait-for {}; wait-error shading.glsl:; screenshot {}; "
        "wait-for {}; wait-no-error; screenshot {}; quit",
        a.string(), (dir / "go1").string(), b.string(), (dir / "go2").string(), c.string());
    const pid_t pid = startViewer(fmt::format("PENUMBRA_SHADER_DIR='{}'", shaders.string()), config("default.json"), script, log);
    ASSERT_GT(pid, 0);
    ViewerGroup reap{pid};

    ASSERT_TRUE(waitForFile(a, pid)) << slurp(log);
    replaceInFile(shading, store, "this is not GLSL;\n    " + store);
    std::ofstream(dir / "go1") << "";
    ASSERT_TRUE(waitForFile(b, pid)) << slurp(log);
    // Fixed, and changed: the colour inverted.
    std::ofstream(shading, std::ios::trunc) << original;
    replaceInFile(shading, store, "imageStore(outColor, pixel, vec4(1.0 - display, 1.0));");
    std::ofstream(dir / "go2") << "";
    int status = 0;
    ASSERT_EQ(waitpid(pid, &status, 0), pid);
    reap.pid = 0;
    ASSERT_TRUE(WIFEXITED(status)) << slurp(log);
    ASSERT_EQ(WEXITSTATUS(status), 0) << slurp(log);

    const std::string out = slurp(log);
    EXPECT_NE(out.find("shading.glsl:"), std::string::npos) << out;
    const Png first = readPng(a), broken = readPng(b), fixed = readPng(c);
    ASSERT_EQ(first.rgba.size(), size_t(96 * 54 * 4));
    EXPECT_EQ(broken.rgba, first.rgba) << "the last good frame stays while the shader is broken";
    ASSERT_EQ(fixed.rgba.size(), first.rgba.size());
    int worst = 0;
    for (size_t i = 0; i < first.rgba.size(); ++i) {
        if (i % 4 == 3) continue;  // alpha stays 1
        worst = std::max(worst, std::abs(int(fixed.rgba[i]) - (255 - int(first.rgba[i]))));
    }
    EXPECT_LE(worst, 1) << "the edited shader's inverted colour";
}

// The Compare panel's figures are `penumbra compare`'s: the same stacks, the same pixels
// (geometry the light reaches), the same reference.
TEST_F(ViewerTest, ComparisonFiguresAreThoseOfPenumbraCompare)
{
    for (const std::string name : {"pcss.json", "two-spots.json"}) {
        SCOPED_TRACE(name);
        const fs::path saved = dir / "saved.json", split = dir / "split.png", difference = dir / "difference.png";
        const RunResult v = viewer(config(name), fmt::format("size 96 54; orbit 10 5; compare reference; compare-set reference.samples=8; "
                                                             "wait-compare; errors; compare-view split; frames 1; screenshot-window {}; "
                                                             "compare-view difference; frames 1; screenshot {}; save {}; quit",
                                                             split.string(), difference.string(), saved.string()));
        ASSERT_EQ(v.exitCode, 0) << v.err;
        const fs::path json = dir / "compare.json";
        ASSERT_EQ(std::system(fmt::format("'{}' compare '{}' --reference-set samples=8 --json > '{}' 2> /dev/null",
                                          penumbra::test::penumbraExecutable().string(), saved.string(), json.string())
                                  .c_str()),
                  0);
        const nlohmann::json cli = nlohmann::json::parse(slurp(json));
        std::istringstream lines(v.out);
        size_t light = 0;
        for (std::string line; std::getline(lines, line);) {
            if (line.rfind("error ", 0) != 0) continue;
            std::istringstream words(line.substr(6));
            std::string lightName, key;
            words >> lightName;
            std::map<std::string, double> figures;
            for (double value = 0.0; words >> key >> value;) figures[key] = value;
            ASSERT_LT(light, cli["lights"].size());
            const nlohmann::json& c = cli["lights"][light]["visibility"];
            EXPECT_EQ(lightName, cli["lights"][light]["name"]);
            EXPECT_EQ(figures["pixels"], c["all"]["pixels"].get<double>());
            // Printed to 6 significant digits.
            EXPECT_NEAR(figures["rmse"], c["all"]["rmse"].get<double>(), 1e-5 * c["all"]["rmse"].get<double>() + 1e-9);
            EXPECT_NEAR(figures["max"], c["all"]["max_abs_error"].get<double>(), 1e-5);
            EXPECT_NEAR(figures["umbra"], c["regions"]["umbra"]["rmse"].get<double>(), 1e-5 * figures["umbra"] + 1e-9);
            EXPECT_NEAR(figures["penumbra"], c["regions"]["penumbra"]["rmse"].get<double>(), 1e-5 * figures["penumbra"] + 1e-9);
            EXPECT_NEAR(figures["lit"], c["regions"]["lit"]["rmse"].get<double>(), 1e-5 * figures["lit"] + 1e-9);
            EXPECT_NEAR(figures["ssim"], c["ssim"].get<double>(), 1e-5);
            ++light;
        }
        EXPECT_EQ(light, cli["lights"].size()) << v.out;
        // The difference image: the frame's size, dark where A and B agree.
        const Png d = readPng(difference);
        EXPECT_EQ(d.width, 96);
        EXPECT_EQ(d.height, 54);
        EXPECT_GT(readPng(split).width, 96);  // the window, panels and both halves
    }
}

// A flown camera path becomes /camera/position and /camera/target tracks; the viewer at a
// time of it shows what `penumbra render` of the saved config draws at that frame.
TEST_F(ViewerTest, ARecordedCameraPathIsSavedAsTracksThatRenderPlays)
{
    const fs::path saved = dir / "path.json", atTime = dir / "at.png";
    const RunResult v = viewer(config("default.json"),
                               fmt::format("size 64 36; record start; orbit 20 0; frames 2; orbit 20 5; frames 2; dolly 0.8; "
                                           "frames 2; record stop; save {}; quit",
                                           saved.string()));
    ASSERT_EQ(v.exitCode, 0) << v.err;
    const json doc = json::parse(slurp(saved));
    ASSERT_TRUE(doc.contains("animation")) << doc.dump();
    const json& tracks = doc["animation"]["tracks"];
    ASSERT_EQ(tracks.size(), 2u);
    for (const json& track : tracks) {
        ASSERT_GE(track["keys"].size(), 4u) << track.dump();  // the start, three moves (and the end)
        for (size_t k = 1; k < track["keys"].size(); ++k) EXPECT_GT(track["keys"][k]["t"], track["keys"][k - 1]["t"]);
    }
    const double fps = doc["animation"]["fps"];
    const uint32_t frames = doc["frames"];
    const double end = tracks[0]["keys"].back()["t"];
    EXPECT_GE(frames, uint32_t(std::ceil(end * fps)) + 1);

    // Playback: frame `f` of the render is time f / fps in the viewer.
    const uint32_t f = frames / 2;
    const RunResult w = viewer(saved.string(), fmt::format("size 64 36; time {}; frames 1; screenshot {}; quit", double(f) / fps, atTime.string()));
    ASSERT_EQ(w.exitCode, 0) << w.err;
    const RunResult r = render(fmt::format("'{}' -o '{}/f{{frame}}.png'", saved.string(), dir.string()));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const Png viewed = readPng(atTime), rendered = readPng(dir / fmt::format("f{}.png", f)), first = readPng(dir / "f0.png");
    ASSERT_EQ(viewed.rgba.size(), rendered.rgba.size());
    int worst = 0;
    for (size_t i = 0; i < viewed.rgba.size(); ++i) worst = std::max(worst, std::abs(int(viewed.rgba[i]) - int(rendered.rgba[i])));
    EXPECT_LE(worst, 1);
    EXPECT_NE(first.rgba, rendered.rgba) << "the camera moved along the path";
}

// The frame is as large as the window less the panel, and follows a resize; `size` fixes it.
TEST_F(ViewerTest, TheRenderSizeFollowsTheWindowUnlessFixed)
{
    const fs::path window = dir / "window.png", view = dir / "view.png", fixed = dir / "fixed.png", save = dir / "s.json";
    const RunResult v = viewer(config("default.json"),
                               fmt::format("window 900 500; frames 3; screenshot-window {}; screenshot {}; ui off; frames 2; "
                                           "size 200 100; frames 2; screenshot {}; save {}; quit",
                                           window.string(), view.string(), fixed.string(), save.string()));
    ASSERT_EQ(v.exitCode, 0) << v.err;
    const Png w = readPng(window), f = readPng(view), s = readPng(fixed);
    EXPECT_EQ(w.width, 900);
    EXPECT_EQ(w.height, 500);
    EXPECT_EQ(f.width, 900 - 440);  // the panel is 440 points wide at scale 1
    EXPECT_EQ(f.height, 500);
    EXPECT_EQ(s.width, 200);
    EXPECT_EQ(s.height, 100);
    const json saved = json::parse(slurp(save));
    EXPECT_EQ(saved["output"]["width"], 200);
    EXPECT_EQ(saved["output"]["height"], 100);
}

// The panels are drawn into a layer of their own and copied into the window: the window
// shows what drawing them into it showed (the pixel inspector's tooltip over the view
// included, drawn over the copy), and panels nobody touches are not built again every
// frame. The two screenshots differ only in the status line ("wrote <file>"), the Timings
// panel (live figures) is closed.
TEST_F(ViewerTest, ThePanelLayerShowsWhatDrawingThePanelsShowsAndIsNotRebuiltEveryFrame)
{
    for (const char* d : {"a", "b", "c"}) fs::create_directories(dir / d);
    // c first: both screenshots then show a status line of the same length (and Dear
    // ImGui, which sizes the scroll bar from the frame before, has had a frame with it).
    const fs::path first = dir / "c" / "w.png", layered = dir / "a" / "w.png", drawn = dir / "b" / "w.png";
    const RunResult v = viewer(config("default.json"),
                               fmt::format("window 1100 560; panel timings closed; frames 3; screenshot-window {}; frames 2; "
                                           "screenshot-window {}; panel-layer off; frames 2; screenshot-window {}; "
                                           "panel-layer on; frames 60; timings; quit",
                                           first.string(), layered.string(), drawn.string()));
    ASSERT_EQ(v.exitCode, 0) << v.err;
    const Png a = readPng(layered), b = readPng(drawn);
    ASSERT_EQ(a.width, 1100);
    ASSERT_EQ(b.width, 1100);
    ASSERT_EQ(a.height, b.height);
    const int statusRows = 100;  // the status line (two lines for this test folder) and its dismiss button
    size_t differ = 0, compared = 0;
    for (int y = 0; y < a.height; ++y) {
        for (int x = 0; x < a.width; ++x) {
            if (x < 440 && y < statusRows) continue;
            const size_t i = (size_t(y) * a.width + x) * 4;
            ++compared;
            differ += !std::equal(a.rgba.begin() + ptrdiff_t(i), a.rgba.begin() + ptrdiff_t(i) + 3, b.rgba.begin() + ptrdiff_t(i));
        }
    }
    EXPECT_EQ(differ, 0u) << "of " << compared << " pixels";
    // 60 frames without input: built at most 4 times a second, and after each command.
    const size_t at = v.err.rfind("built in ");
    ASSERT_NE(at, std::string::npos) << v.err;
    int built = -1, frames = -1;
    ASSERT_EQ(std::sscanf(v.err.c_str() + at, "built in %d of the last %d frames", &built, &frames), 2) << v.err.substr(at);
    EXPECT_LE(built, frames / 2) << v.err.substr(at, 80);
    EXPECT_GE(frames, 60);
}

// A rebuilt plugin library is loaded again without a restart, keeping the light's
// parameters, for A and for B; a damaged one shows its error and the last frame stays.
TEST_F(ViewerTest, ARebuiltPluginIsReloadedKeepingTheParameters)
{
    const fs::path plugins = dir / "plugins";
    fs::create_directories(plugins);
    const fs::path built = penumbra::test::buildPluginDir() / "penumbra-hard.so", plugin = plugins / "penumbra-hard.so";
    fs::copy_file(built, plugin);
    const fs::path a = dir / "a.png", b = dir / "b.png", c = dir / "c.png", saved = dir / "saved.json", log = dir / "viewer.log";
    const std::string script = fmt::format(
        "size 96 54; set hard.pcf_kernel=5; compare hard; wait-compare; frames 2; screenshot {}; wait-for {}; "
        "wait-error penumbra-hard.so; screenshot {}; wait-for {}; wait-no-error; wait-compare; screenshot {}; save {}; quit",
        a.string(), (dir / "go1").string(), b.string(), (dir / "go2").string(), c.string(), saved.string());
    const pid_t pid = startViewer(fmt::format("PENUMBRA_PLUGIN_PATH='{}'", plugins.string()), config("default.json"), script, log);
    ASSERT_GT(pid, 0);
    ViewerGroup reap{pid};

    ASSERT_TRUE(waitForFile(a, pid)) << slurp(log);
    // "Rebuilt" into a file that is no library (a build that failed half-way).
    fs::remove(plugin);
    std::ofstream(plugin) << "not a shared library";
    std::ofstream(dir / "go1") << "";
    ASSERT_TRUE(waitForFile(b, pid)) << slurp(log);
    fs::remove(plugin);
    fs::copy_file(built, plugin);
    std::ofstream(dir / "go2") << "";
    int status = 0;
    ASSERT_EQ(waitpid(pid, &status, 0), pid);
    reap.pid = 0;
    ASSERT_TRUE(WIFEXITED(status)) << slurp(log);
    ASSERT_EQ(WEXITSTATUS(status), 0) << slurp(log);

    const std::string out = slurp(log);
    EXPECT_NE(out.find("reloaded the plugins"), std::string::npos) << out;
    // B (here the same technique) follows: a new worker opens the fresh copies, and draws.
    EXPECT_NE(out.find("B: a new worker with the plugins of"), std::string::npos) << out;
    const Png first = readPng(a), broken = readPng(b), reloaded = readPng(c);
    ASSERT_EQ(first.rgba.size(), size_t(96 * 54 * 4));
    EXPECT_EQ(broken.rgba, first.rgba) << "the last good frame stays while the plugin does not load";
    EXPECT_EQ(reloaded.rgba, first.rgba) << "the same plugin with the same parameters draws the same frame";
    EXPECT_EQ(json::parse(slurp(saved))["lights"][0]["shadow"]["pcf_kernel"], 5);
}

// A glTF file's own animation: opened directly it plays its first clip, and the saved
// config plays it in `penumbra render` as the viewer showed it.
TEST_F(ViewerTest, AGltfAnimationPlaysAsRenderDrawsIt)
{
    const fs::path shot = dir / "at.png", saved = dir / "anim.json";
    const RunResult v = viewer((penumbra::test::testDataDir() / "gltf" / "animated.gltf").string(),
                               fmt::format("size 64 36; time 1; frames 1; screenshot {}; save {}; quit", shot.string(), saved.string()));
    ASSERT_EQ(v.exitCode, 0) << v.err;
    const json doc = json::parse(slurp(saved));
    EXPECT_EQ(doc["scene"]["animation"], "wave");
    EXPECT_EQ(doc["frames"], 61);  // 2 s at 30 fps, both ends
    const RunResult r = render(fmt::format("'{}' -o '{}/f{{frame}}.png'", saved.string(), dir.string()));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const Png viewed = readPng(shot), rendered = readPng(dir / "f30.png"), rest = readPng(dir / "f0.png");
    ASSERT_EQ(viewed.rgba.size(), rendered.rgba.size());
    int worst = 0;
    for (size_t i = 0; i < viewed.rgba.size(); ++i) worst = std::max(worst, std::abs(int(viewed.rgba[i]) - int(rendered.rgba[i])));
    EXPECT_LE(worst, 1);
    EXPECT_NE(rest.rgba, rendered.rgba) << "the quad moved";
}

// A viewer user's rough edges (issue 43): on a 1600 x 900 screen the window fits; an
// animated camera is followed until an orbit frees it, and the camera panel shows the pose
// drawn; the inspector gives A, B and their difference; a debug image keeps its aspect;
// Save writes every technique parameter.
TEST_F(ViewerTest, ASmallScreenAFollowedOrFreeCameraTheInspectorAgainstBAndAnExplicitSave)
{
    const fs::path window = dir / "window.png", debug = dir / "debug.png", saved = dir / "saved.json";
    const RunResult v = viewer(config("animated.json"),
                               fmt::format("frames 2; print-camera; orbit 40 10; frames 2; print-camera; camera-track follow; "
                                           "frames 2; print-camera; screenshot-window {}; size 64 36; compare reference; "
                                           "wait-compare; inspect 32 30; show light0.hard.shadow_map; frames 2; "
                                           "screenshot-window {}; save {}; quit",
                                           window.string(), debug.string(), saved.string()),
                               fmt::format("xvfb-run -a -n {} -s '-screen 0 1600x900x24'", 100 + ::getpid() % 5000 * 4));
    ASSERT_EQ(v.exitCode, 0) << v.err;
    // "camera follow|free drawn PX PY PZ TX TY TZ panel PX PY PZ TX TY TZ"
    std::vector<std::pair<std::string, std::vector<double>>> poses;
    std::istringstream lines(v.out);
    std::vector<std::string> inspected;
    for (std::string line; std::getline(lines, line);) {
        if (line.rfind("inspect ", 0) == 0) inspected.push_back(line);
        if (line.rfind("camera ", 0) != 0) continue;
        std::istringstream words(line.substr(7));
        std::string mode, word;
        std::vector<double> numbers;
        words >> mode;
        for (double x; words >> word;) {
            if (std::sscanf(word.c_str(), "%lf", &x) == 1) numbers.push_back(x);
        }
        ASSERT_EQ(numbers.size(), 12u) << line;
        poses.emplace_back(mode, numbers);
    }
    ASSERT_EQ(poses.size(), 3u) << v.out;
    EXPECT_EQ(poses[0].first, "follow");
    EXPECT_EQ(poses[1].first, "free");
    EXPECT_EQ(poses[2].first, "follow");
    for (const auto& [mode, n] : poses) {
        for (int i = 0; i < 6; ++i) EXPECT_NEAR(n[i], n[6 + i], 1e-3 * (1.0 + std::abs(n[i]))) << mode << ": panel != drawn";
    }
    // The orbit moved the drawn eye; following again shows the track's pose once more.
    const double moved = std::hypot(poses[1].second[0] - poses[0].second[0], poses[1].second[2] - poses[0].second[2]);
    EXPECT_GT(moved, 0.1);
    for (int i = 0; i < 6; ++i) EXPECT_NEAR(poses[2].second[i], poses[0].second[i], 1e-3 * (1.0 + std::abs(poses[0].second[i])));

    const Png w = readPng(window);
    EXPECT_LE(w.width, 1600);
    EXPECT_LE(w.height, 900);
    EXPECT_GT(w.width, 800);

    ASSERT_GE(inspected.size(), 3u) << v.out;
    EXPECT_NE(inspected[2].find(" A "), std::string::npos) << inspected[2];
    EXPECT_NE(inspected[2].find(" B "), std::string::npos) << inspected[2];
    EXPECT_NE(inspected[2].find(" dV "), std::string::npos) << inspected[2];

    // The square shadow map: the bounding box of what is not background right of the panel.
    const Png d = readPng(debug);
    const int panel = 440;
    int x0 = d.width, x1 = -1, y0 = d.height, y1 = -1;
    for (int y = 0; y < d.height; ++y)
        for (int x = panel; x < d.width; ++x) {
            const uint8_t* p = &d.rgba[(size_t(y) * d.width + x) * 4];
            if (std::abs(p[0] - 23) + std::abs(p[1] - 23) + std::abs(p[2] - 25) <= 3) continue;
            x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
        }
    ASSERT_GT(x1, x0);
    EXPECT_NEAR(double(x1 - x0 + 1) / double(y1 - y0 + 1), 1.0, 0.01) << x0 << " " << x1 << " " << y0 << " " << y1;

    // Every parameter of every light's technique, defaults included.
    const json config = json::parse(slurp(saved));
    for (const json& light : config["lights"]) {
        for (const char* param : {"resolution", "depth_bias", "slope_bias", "bias_mode", "filter", "pcf_kernel"}) {
            EXPECT_TRUE(light["shadow"].contains(param)) << light["shadow"].dump();
        }
    }
    EXPECT_TRUE(config.contains("shadow_focus"));
}

// Nothing reads the light's visibility image while the view is only looked at: shading
// evaluates hard's visibility function and no image is written. A command that reads V
// (inspect) draws the frame again with the image, the same picture; the next frame drawn
// for a change writes none again. (The panels are off: a cursor over the view would be
// the pixel inspector reading V.)
TEST_F(ViewerTest, TheVisibilityImageIsWrittenOnlyWhileSomethingReadsIt)
{
    const fs::path before = dir / "before.png", inspected = dir / "inspected.png";
    const RunResult v = viewer(config("default.json"),
                               fmt::format("ui off; size 160 90; frames 2; timings; screenshot {}; inspect 80 60; timings; "
                                           "screenshot {}; orbit 5 0; frames 2; timings; quit",
                                           before.string(), inspected.string()));
    ASSERT_EQ(v.exitCode, 0) << v.err;
    std::vector<std::string> states;
    std::string inspect;
    std::istringstream lines(v.out + v.err);
    for (std::string line; std::getline(lines, line);) {
        if (const size_t at = line.find("timing visibility "); at != std::string::npos) states.push_back(line.substr(at));
        if (line.rfind("inspect ", 0) == 0 && line.find(" V ") != std::string::npos) inspect = line;
    }
    ASSERT_EQ(states.size(), 3u) << v.out << v.err;
    EXPECT_NE(states[0].find("evaluated in shading"), std::string::npos) << states[0];
    EXPECT_NE(states[1].find("an image"), std::string::npos) << states[1];
    EXPECT_NE(states[2].find("evaluated in shading"), std::string::npos) << states[2];
    EXPECT_FALSE(inspect.empty()) << "inspect printed the light's V: " << v.out;
    const Png a = readPng(before), b = readPng(inspected);
    ASSERT_EQ(a.rgba.size(), b.rgba.size());
    EXPECT_TRUE(a.rgba == b.rgba) << "the frame drawn with the image is the frame drawn without it";
}

// A slow frame of A (the reference, traced on the CPU) draws the window meanwhile with its
// progress, and a cancel leaves the last complete image and the config it drew.
TEST_F(ViewerTest, ASlowFrameOfAShowsProgressAndACancelKeepsTheLastImage)
{
    const fs::path before = dir / "before.png", after = dir / "after.png", saved = dir / "saved.json";
    const RunResult v = viewer(config("pcss.json"),
                               fmt::format("size 96 54; frames 2; screenshot {}; technique 0 reference; param 0 samples 4096; "
                                           "param 0 cache false; cancel-after 0.6; frames 2; screenshot {}; expect-no-error; "
                                           "save {}; quit",
                                           before.string(), after.string(), saved.string()));
    ASSERT_EQ(v.exitCode, 0) << v.err;
    EXPECT_NE(v.err.find("window frame(s) shown while the frame drew"), std::string::npos) << v.err;
    const size_t at = v.err.find("A: cancelled after");
    ASSERT_NE(at, std::string::npos) << v.err;
    double percent = -1.0;
    const size_t pct = v.err.find(" at ", at);
    ASSERT_NE(pct, std::string::npos);
    std::sscanf(v.err.c_str() + pct, " at %lf %%", &percent);
    EXPECT_GT(percent, 0.0) << v.err;
    EXPECT_LT(percent, 100.0) << v.err;
    const Png a = readPng(before), b = readPng(after);
    EXPECT_EQ(a.rgba, b.rgba);  // the last complete image
    const json config = json::parse(slurp(saved));
    EXPECT_EQ(config["lights"][0]["shadow"]["technique"], "pcss");  // the edit is undone
}
