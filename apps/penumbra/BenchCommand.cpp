#include "BenchCommand.h"

#include "BenchResults.h"
#include "ConfigCheck.h"
#include "FloorComparison.h"
#include "FrameCapture.h"
#include "OutputFolder.h"
#include "ParetoPlot.h"
#include "Phase.h"
#include "ReferenceTechnique.h"
#include "TimingSummary.h"

#include "penumbra/config/Animation.h"
#include "penumbra/config/ConfigWriter.h"
#include "penumbra/config/Run.h"
#include "penumbra/config/Sweep.h"
#include "penumbra/core/Error.h"
#include "penumbra/frame/FloorRenderer.h"
#include "penumbra/frame/FrameRenderer.h"
#include "penumbra/frame/SceneResources.h"
#include "penumbra/io/StagedFile.h"
#include "penumbra/metrics/ImageComparison.h"
#include "penumbra/plugin/PluginRegistry.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <sys/utsname.h>
#include <unistd.h>

#include <csignal>
#include <ctime>
#include <fstream>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <thread>

using nlohmann::json;
namespace fs = std::filesystem;

namespace penumbra::app {
namespace {

struct BenchFlags {
    std::string config;
    std::string output;                // -o DIR; empty: print the table only
    std::string summary;               // --summary FILE.md; empty: none
    uint32_t frames = 10;              // measured frames per variant
    uint32_t warmup = 1;               // untimed frames before them
    bool animate = false;              // --animate: frame k of a variant is posed at frame k
    ReferenceFlags reference;
    RunFlags run;                      // --set and the size, every variant
    DeviceFlags device;
    std::vector<std::string> command;  // argv, for the reports
};

// ---- interruption ---------------------------------------------------------------------
// SIGINT or SIGTERM ends the run after the frame in flight, through the normal unwinding
// (every renderer destroyed, nothing written): a run stopped half-way has no results to
// show, and a staged file must not be left behind by a kill in the middle of a write. A
// second signal ends the process at once (SA_RESETHAND).

volatile std::sig_atomic_t gInterrupted = 0;  // the signal's number

extern "C" void onInterrupt(int signal) { gInterrupted = signal; }

struct Interrupted {
    int signal = 0;
};

class InterruptHandler {
public:
    InterruptHandler()
    {
        gInterrupted = 0;
        struct sigaction action {};
        action.sa_handler = onInterrupt;
        sigemptyset(&action.sa_mask);
        action.sa_flags = SA_RESETHAND;
        sigaction(SIGINT, &action, &oldInt_);
        sigaction(SIGTERM, &action, &oldTerm_);
    }
    ~InterruptHandler()
    {
        sigaction(SIGINT, &oldInt_, nullptr);
        sigaction(SIGTERM, &oldTerm_, nullptr);
    }
    InterruptHandler(const InterruptHandler&) = delete;
    InterruptHandler& operator=(const InterruptHandler&) = delete;

    static void check()
    {
        if (gInterrupted) throw Interrupted{int(gInterrupted)};
    }

private:
    struct sigaction oldInt_ {};
    struct sigaction oldTerm_ {};
};

// ---- progress on stderr ---------------------------------------------------------------
// One log line per variant; on a terminal, a bar over all the run's frames instead,
// redrawn in place.
class Progress {
public:
    Progress(size_t variants, uint32_t framesPerVariant)
        : bar_(::isatty(STDERR_FILENO) == 1), variants_(variants), total_(variants * framesPerVariant)
    {
    }
    ~Progress() { clear(); }
    Progress(const Progress&) = delete;
    Progress& operator=(const Progress&) = delete;

    void startVariant(size_t index, const std::string& label)
    {
        variant_ = index;
        label_ = label;
        if (bar_) draw();
        else spdlog::info("variant {}/{}: {}", index + 1, variants_, label);
    }
    void frameDone()
    {
        ++done_;
        if (bar_) draw();
    }
    // Before a log line, so that it does not run into the bar.
    void clear()
    {
        if (bar_ && drawn_) fmt::print(stderr, "\r\x1b[K");
        drawn_ = false;
    }

private:
    // Redrawn only when what it shows changes: frames of a small image take a
    // millisecond, and a terminal need not be written a thousand times a second.
    void draw()
    {
        constexpr size_t kWidth = 24, kLabel = 60;
        const size_t percent = total_ ? done_ * 100 / total_ : 100;
        if (drawn_ && percent == drawnPercent_ && variant_ == drawnVariant_) return;
        drawnPercent_ = percent;
        drawnVariant_ = variant_;
        const size_t filled = total_ ? done_ * kWidth / total_ : kWidth;
        const std::string label = label_.size() > kLabel ? label_.substr(0, kLabel - 3) + "..." : label_;
        fmt::print(stderr, "\r\x1b[K[{}{}] {:3}% variant {}/{}: {}", std::string(filled, '#'), std::string(kWidth - filled, '.'),
                   percent, variant_ + 1, variants_, label);
        std::fflush(stderr);
        drawn_ = true;
    }

    bool bar_;
    bool drawn_ = false;
    size_t drawnPercent_ = 0;
    size_t drawnVariant_ = 0;
    size_t variants_;
    size_t total_;
    size_t done_ = 0;
    size_t variant_ = 0;
    std::string label_;
};

// ---- what the reports say about the machine -------------------------------------------

json machineJson()
{
    json machine = json::object();
    utsname name{};
    if (::uname(&name) == 0) {
        machine["os"] = fmt::format("{} {}", name.sysname, name.release);
        machine["arch"] = name.machine;
    }
    std::ifstream cpuinfo("/proc/cpuinfo");
    for (std::string line; std::getline(cpuinfo, line);) {
        if (line.rfind("model name", 0) != 0) continue;
        const size_t colon = line.find(':');
        if (colon != std::string::npos) machine["cpu"] = line.substr(line.find_first_not_of(' ', colon + 1));
        break;
    }
    machine["cpu_threads"] = std::thread::hardware_concurrency();
    return machine;
}

json deviceJson(const gpu::DeviceInfo& d)
{
    return {{"name", d.name},
            {"type", d.type},
            {"vulkan", fmt::format("{}.{}.{}", VK_API_VERSION_MAJOR(d.apiVersion), VK_API_VERSION_MINOR(d.apiVersion),
                                   VK_API_VERSION_PATCH(d.apiVersion))},
            {"driver", d.driverInfo}};
}

std::string utcNow()
{
    const std::time_t now = std::time(nullptr);
    std::tm utc{};
    gmtime_r(&now, &utc);
    char text[32];
    std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &utc);
    return text;
}

// ---- sweep variants ---------------------------------------------------------------------

// Whether a sweep entry sets light `light`'s shadow settings (its technique or parameters).
bool setsShadowOf(const config::SweepChoice& choice, size_t light)
{
    const std::string shadow = fmt::format("/lights/{}/shadow", light);
    return std::all_of(choice.paths.begin(), choice.paths.end(), [&](const std::string& p) {
        return p.rfind(shadow, 0) == 0 && (p.size() == shadow.size() || p[shadow.size()] == '/');
    });
}

// A choice as a table or a plot shows it: its label when the entry names its values, else
// "<last path token>=<value>" ("resolution=512").
std::string choiceText(const config::SweepChoice& choice)
{
    if (choice.labelled) return choice.label;
    std::vector<std::string> names;
    for (const std::string& p : choice.paths) names.push_back(p.substr(p.rfind('/') + 1));
    return fmt::format("{}={}", fmt::join(names, "+"), choice.label);
}

// The variant's choices that set light `light`'s shadow (technique = true), or the others.
std::string choicesText(const config::SweepVariant& variant, size_t light, bool technique)
{
    std::vector<std::string> parts;
    for (const config::SweepChoice& c : variant.choices) {
        if (setsShadowOf(c, light) == technique) parts.push_back(choiceText(c));
    }
    return fmt::format("{}", fmt::join(parts, ", "));
}

// Everything a variant would fail on, for every variant, before the first renders
// (ConfigCheck.h): each distinct error once, with the variants it is in.
void checkVariants(const config::SweepVariants& variants, const config::RunOptions& options,
                   plugin::PluginRegistry& plugins)
{
    ConfigCheck check(options, plugins, variants.size());
    for (size_t i = 0; i < variants.size(); ++i) {
        inPhase(fmt::format("checking sweep variant {} of {}", i + 1, variants.size()),
                [&] { check.checkVariant(variants, i); });
    }
    check.checkOverridesUsed();
    std::vector<std::string> errors;
    for (const ConfigCheck::Finding& error : check.errors()) errors.push_back(check.describe(error));
    if (!errors.empty()) throw Error(fmt::format("{}", fmt::join(errors, "\n")));
}

// ---- the reference, once per distinct (scene, camera, light, image size) -----------------

// What a light's reference visibility depends on, as text: the scene (its source, and the
// poses its node tracks give it at frame 0), the camera, the light itself and the image
// size. Techniques, other lights and culling do not enter.
std::string referenceKey(const config::RenderConfig& config, size_t light)
{
    const auto vec = [](const glm::vec3& v) { return json::array({v.x, v.y, v.z}); };
    json nodes = json::array();
    for (const config::AnimationTrack& track : config.animation.tracks) {
        if (track.target.rfind("node:", 0) == 0) nodes.push_back({track.target, config::evaluate(track, 0.0f)});
    }
    const scene::Camera& c = config.camera;
    const scene::Light& l = config.lights[light].light;
    return json{{"scene", {config::sceneJson(config.scene, "/"), nodes}},
                {"camera", {vec(c.position), vec(c.target), vec(c.up), c.fovYDeg, c.nearWorld}},
                {"light",
                 {scene::lightTypeName(l.type), vec(l.position), vec(l.direction), vec(l.tangent), l.outerConeDeg,
                  l.innerConeDeg, l.angularDiameterDeg, l.sizeWorld.x, l.sizeWorld.y, l.radiusWorld}},
                {"size", {config.width, config.height}}}
        .dump();
}

struct ReferenceVisibility {
    std::vector<float> visibility;
    // The pixels the light's figures are taken over (reachMask: geometry the light reaches).
    metrics::PixelMask mask;
};

class ReferenceCache {
public:
    ReferenceCache(plugin::PluginRegistry& plugins, const ReferenceTechnique& reference)
        : plugins_(plugins), reference_(reference)
    {
    }

    // The reference visibility of each light of `config` (posed at frame 0, drawing
    // `scene`), rendering those not seen before in one frame.
    std::vector<const ReferenceVisibility*> lookUp(const config::RenderConfig& config,
                                                    const std::shared_ptr<frame::SceneResources>& scene, Progress& progress)
    {
        std::vector<std::string> keys;
        config::RenderConfig missing = config;
        missing.lights.clear();
        missing.animation = {};  // posed already; its light indices would not match the subset
        std::vector<std::string> missingKeys;
        for (size_t l = 0; l < config.lights.size(); ++l) {
            keys.push_back(referenceKey(config, l));
            if (cache_.count(keys.back()) || std::count(missingKeys.begin(), missingKeys.end(), keys.back())) continue;
            missing.lights.push_back(config.lights[l]);
            missingKeys.push_back(keys.back());
        }
        if (!missing.lights.empty()) render(withReferenceShadows(missing, reference_), scene, missingKeys, progress);
        std::vector<const ReferenceVisibility*> found;
        for (const std::string& key : keys) found.push_back(&cache_.at(key));
        return found;
    }

    size_t renders() const { return renders_; }

private:
    void render(const config::RenderConfig& config, const std::shared_ptr<frame::SceneResources>& scene,
                const std::vector<std::string>& keys, Progress& progress)
    {
        progress.clear();
        spdlog::info("reference: rendering {} light(s) with {}", config.lights.size(), reference_.shadow.technique);
        frame::FrameRenderer renderer(scene, config, plugins_);
        renderer.renderFrame();
        InterruptHandler::check();
        FrameImages images = captureFrame(renderer);
        for (size_t i = 0; i < keys.size(); ++i) {
            cache_[keys[i]] = {std::move(images.visibility[i]),
                               reachMask(config.lights[i].light, images.width, images.height, images.positions)};
        }
        ++renders_;
    }

    plugin::PluginRegistry& plugins_;
    const ReferenceTechnique& reference_;
    std::map<std::string, ReferenceVisibility> cache_;
    size_t renders_ = 0;
};

// ---- measuring one variant ----------------------------------------------------------------

// The scenes of the sweep's variants. Variants over one scene source share its scene and
// its GPU resources (frame::SceneResources: upload, BVH, shaders, the engine's pipelines),
// the reference renders too; an animated variant poses a scene of its own. The resources
// of the last scene and batching drawn are kept, no more, so that a sweep over many
// scenes holds one on the device at a time.
class VariantScenes {
public:
    explicit VariantScenes(gpu::Context& context) : context_(context) {}

    std::shared_ptr<frame::SceneResources> resources(const scene::Scene& scene, const config::RenderConfig& config)
    {
        const render::DrawBatching batching = frame::SceneResources::batchingOf(config);
        if (!last_ || &last_->scene() != &scene || last_->batching() != batching) {
            last_.reset();  // before the next one is made: one scene's memory at a time
            last_ = std::make_shared<frame::SceneResources>(context_, scene, batching);
        }
        return last_;
    }
    config::SceneCache& scenes() { return scenes_; }
    // Scenes built for the run: one per scene source of unanimated variants, one per
    // animated variant.
    size_t scenesBuilt() const { return scenes_.scenesBuilt() + posedScenes_; }
    void countPosedScene() { ++posedScenes_; }

private:
    gpu::Context& context_;
    config::SceneCache scenes_;
    size_t posedScenes_ = 0;
    std::shared_ptr<frame::SceneResources> last_;
};

struct BenchSession {
    const BenchFlags& flags;
    plugin::PluginRegistry& plugins;
    const config::RunOptions& options;
    ReferenceCache& references;
    VariantScenes& scenes;
    Progress& progress;
    std::vector<std::string>& warnings;
};

BenchVariant measureVariant(BenchSession& session, const config::SweepVariant& variant, size_t index)
{
    // An animated config is measured at its first frame, as `render` shows it, unless the
    // run walks along its animation (--animate); it poses a scene of its own.
    std::optional<config::PreparedRun> posed;
    config::RenderConfig unposed;
    const scene::Scene* scenePtr = nullptr;
    if (config::animated(variant.config)) {
        posed.emplace(config::prepareRun(variant.config, session.options));
        posed->poseAtFrame(0);
        session.scenes.countPosedScene();
        scenePtr = &posed->scene;
    } else {
        config::RenderConfig c = variant.config;
        const config::SceneBuild& built = session.scenes.scenes().build(c, session.options);
        unposed = config::resolveRun(std::move(c), session.options, built);
        scenePtr = &built.scene;
    }
    const bool walk = session.flags.animate && posed.has_value();
    const config::RenderConfig& config = posed ? posed->config : unposed;
    const scene::Scene& scene = *scenePtr;
    const std::shared_ptr<frame::SceneResources> resources = session.scenes.resources(scene, config);
    // Walking, each measured frame looks up its own pose's reference.
    std::vector<const ReferenceVisibility*> references;
    if (!walk) references = session.references.lookUp(config, resources, session.progress);

    frame::FrameRenderer renderer(resources, config, session.plugins);
    for (const std::string& warning : renderer.warnings()) {
        session.progress.clear();
        session.warnings.push_back(fmt::format("variant {} ({}): {}", index, variant.label, warning));
        spdlog::warn("{}", session.warnings.back());
    }
    // The floor of the same config (frame/FloorRenderer.h), drawn after every frame so that
    // both are measured side by side.
    frame::FloorRenderer floor(resources->context(), scene, config);
    std::vector<frame::FrameTimings> measured, floorMeasured;
    // Walking: every measured frame's visibility and its pose's reference, stacked frame
    // under frame, so that the errors are over the whole path.
    std::vector<std::vector<float>> pathVisibility(config.lights.size()), pathReference(config.lights.size());
    std::vector<metrics::PixelMask> pathMask(config.lights.size());
    for (uint32_t frame = 0; frame < session.flags.warmup + session.flags.frames; ++frame) {
        if (walk && frame > 0) {
            const std::vector<uint32_t> moved = posed->poseAtFrame(frame);
            renderer.update(config, scene, moved);
            floor.update(config, scene, moved);
        }
        frame::FrameTimings timings = renderer.renderFrame();
        frame::FrameTimings floorTimings = floor.renderFrame();
        if (frame >= session.flags.warmup) {
            measured.push_back(std::move(timings));
            floorMeasured.push_back(std::move(floorTimings));
            if (walk) {
                const FrameImages posed = captureFrame(renderer);
                references = session.references.lookUp(config, resources, session.progress);
                for (size_t l = 0; l < config.lights.size(); ++l) {
                    const ReferenceVisibility& r = *references[l];
                    pathVisibility[l].insert(pathVisibility[l].end(), posed.visibility[l].begin(), posed.visibility[l].end());
                    pathReference[l].insert(pathReference[l].end(), r.visibility.begin(), r.visibility.end());
                    pathMask[l].width = r.mask.width;
                    pathMask[l].height += r.mask.height;
                    pathMask[l].covered.insert(pathMask[l].covered.end(), r.mask.covered.begin(), r.mask.covered.end());
                }
            }
        }
        session.progress.frameDone();
        InterruptHandler::check();
    }
    const FrameImages images = captureFrame(renderer);
    // The passes' transient resources and the techniques' persistent ones (imported).
    std::vector<graph::TransientMemory> memory = renderer.executor().transientMemory();
    std::ranges::copy(renderer.executor().importedMemory(), std::back_inserter(memory));
    std::set<std::string, std::less<>> hostPasses;  // their cost is CPU time
    for (const graph::CompiledPass& pass : renderer.executor().compiled()->passes) {
        if (pass.queue == graph::QueueKind::Host) hostPasses.insert(pass.name);
    }

    BenchVariant result;
    result.index = index;
    result.label = variant.label;
    result.choices = variant.choices;
    result.scene = config.scene.describe();
    // The scene as the config gives it (its files named as from the config's folder).
    result.sceneParams = config::sceneJson(config.scene, config.file);
    result.width = images.width;
    result.height = images.height;
    result.frame = summarizeTimings(measured, "", hostPasses);
    result.floor = compareWithFloor(result.frame, cameraPasses(*renderer.executor().compiled(), images.width, images.height),
                                    summarizeFloor(floorMeasured, config.lights.size()), anyLightShadowed(renderer));
    result.culling = config::cullingModeName(config.culling);
    result.cullingStats = medianCulling(measured);
    const std::vector<std::vector<plugin::TechniqueFigure>> figures = medianTechniqueFigures(measured);
    for (size_t l = 0; l < config.lights.size(); ++l) {
        BenchLight light;
        light.index = l;
        light.name = config.lights[l].name;
        const std::string& technique = images.techniques[l];
        light.technique = technique.empty() ? "unshadowed" : technique;
        light.params = technique.empty() || config.lights[l].shadow.unshadowed()
                           ? json(nullptr)
                                         : plugin::resolveParams(session.plugins.load(technique), config.lights[l].shadow).toJson();
        light.techniqueLabel = choicesText(variant, l, true);
        light.contextLabel = choicesText(variant, l, false);
        const std::string prefix = renderer.shadowPassPrefix(l);
        light.timing = summarizeTimings(measured, prefix, hostPasses);
        if (l < figures.size()) light.figures = figures[l];
        for (const graph::TransientMemory& m : memory) {
            if (m.name.rfind(prefix, 0) == 0) light.memory.push_back(m);
        }
        if (walk) {
            const uint32_t height = images.height * uint32_t(measured.size());
            light.visibility = metrics::compareVisibility({images.width, height, pathVisibility[l]},
                                                          {images.width, height, pathReference[l]}, &pathMask[l]);
        } else {
            const ReferenceVisibility& reference = *references[l];
            light.visibility = metrics::compareVisibility({images.width, images.height, images.visibility[l]},
                                                          {images.width, images.height, reference.visibility},
                                                          &reference.mask);
        }
        result.lights.push_back(std::move(light));
    }
    return result;
}

void printTable(const BenchRun& run)
{
    fmt::print("bench {}: {} variant(s) over {} scene(s) built, medians of {} frame(s) after {} warm-up; reference {} {} "
               "({} render(s))\n",
               run.config, run.variants.size(), run.scenesBuilt, run.frames, run.warmup, run.reference,
               run.referenceParams.dump(), run.referenceRenders);
    fmt::print("  {:>3} {:<12} {:<12} {:>10} {:>10} {:>8} {:>12} {:>9} {:>9}  {}\n", "#", "light", "technique", "ms",
               "frame ms", "x floor", "memory B", "RMSE", "SSIM", "variant (* Pareto front)");
    for (const BenchVariant& v : run.variants) {
        for (const BenchLight& l : v.lights) {
            fmt::print("  {:>3} {:<12} {:<12} {:>10.3f} {:>10.3f} {:>8.2f} {:>12} {:>9.5f} {:>9.5f}  {}{}\n", v.index, l.name,
                       l.technique, l.timing.workMs, v.frame.frameWallMs, v.floor.frameMultiple, l.memoryBytes(),
                       l.visibility.all.rmse, l.visibility.ssim, l.paretoFront ? "* " : "  ",
                       v.label.empty() ? "(no sweep)" : v.label);
        }
    }
    // Every pass against the floor, per variant (FloorComparison.h states the rule).
    fmt::print("against the floor (GPU ms of passes; {})\n", kFloorRule);
    for (const BenchVariant& v : run.variants) fmt::print("  {:>3} {}\n", v.index, floorLine(v));
}

int runBench(const BenchFlags& flags)
{
    if (flags.frames == 0) throw Error("--frames must be at least 1 (the measured frames)");
    const config::ConfigDocument document = inPhase("loading the config", [&] { return config::loadDocument(flags.config); });
    const config::SweepVariants variants(document);
    config::RunOptions options = runOptions(flags.run);
    options.overridesOfUsedTechniquesOnly = true;
    // A bench measures what each technique costs per frame: every pass runs every frame,
    // also where the scene stands still (keeping it would measure nothing).
    options.keepUnchanged = false;

    plugin::PluginRegistry plugins;
    const ReferenceTechnique reference = loadReferenceTechnique(flags.reference.technique, flags.reference.settings, plugins);
    checkVariants(variants, options, plugins);

    const fs::path dir = outputFolder(flags.output);
    const fs::path csvFile = dir / "results.csv", jsonFile = dir / "results.json", plotFile = dir / "pareto.svg";
    const std::string outputFlag = fmt::format("-o {}", dir.string());
    if (!flags.output.empty()) checkOutputFolder(dir, {csvFile, jsonFile, plotFile}, outputFlag);
    // The summary's folder is made like -o's (often it is -o's: -o out --summary out/summary.md).
    const fs::path summary = flags.summary;
    const fs::path summaryDir = summary.has_parent_path() ? summary.parent_path() : fs::path(".");
    const std::string summaryFlag = fmt::format("--summary {} (folder {})", flags.summary, summaryDir.string());
    if (!flags.summary.empty()) checkOutputFolder(summaryDir, {summary}, summaryFlag);

    const InterruptHandler interruptHandler;
    gpu::Context context(contextOptions(flags.device));
    spdlog::info("device: {} ({})", context.deviceInfo().name, context.deviceInfo().type);
    BenchRun run;
    run.config = flags.config;
    run.command = flags.command;
    run.date = utcNow();
    run.machine = machineJson();
    run.device = deviceJson(context.deviceInfo());
    run.frames = flags.frames;
    run.warmup = flags.warmup;
    run.animated = flags.animate;
    run.reference = flags.reference.technique;
    run.referenceParams = reference.params;
    run.notes = variants.variant(0).config.notes;  // a sweep of /notes: the first variant's
    try {
        ReferenceCache references(plugins, reference);
        VariantScenes scenes(context);
        Progress progress(variants.size(), flags.warmup + flags.frames);
        BenchSession session{flags, plugins, options, references, scenes, progress, run.warnings};
        for (size_t i = 0; i < variants.size(); ++i) {
            // Made one at a time: a variant is a copy of the document.
            inPhase(fmt::format("measuring sweep variant {} of {}", i + 1, variants.size()), [&] {
                const config::SweepVariant variant = variants.variant(i);
                progress.startVariant(i, variant.label.empty() ? "(no sweep)" : variant.label);
                run.variants.push_back(measureVariant(session, variant, i));
            });
        }
        run.referenceRenders = references.renders();
        run.scenesBuilt = scenes.scenesBuilt();
    } catch (const Interrupted& interrupted) {
        fmt::print(stderr, "penumbra: interrupted after {} of {} variant(s); nothing written\n", run.variants.size(),
                   variants.size());
        return 128 + interrupted.signal;  // as the shell reports a process the signal ended
    }
    markParetoFronts(run);

    // Files first: figures on stdout mean that the files are there too. The -o set goes
    // into a staging folder that then takes the folder's place, all or nothing, with the
    // summary when it is written into the same folder.
    const bool summaryInSet = !flags.output.empty() && !flags.summary.empty() && sameFolder(summaryDir, dir);
    if (!flags.output.empty()) {
        OutputSet set(dir, outputFlag);
        io::writeTextFile(set.folder() / plotFile.filename(), paretoSvg(run));
        io::writeTextFile(set.folder() / csvFile.filename(), resultsCsv(run));
        io::writeTextFile(set.folder() / jsonFile.filename(), resultsJson(run).dump(2) + "\n");
        if (summaryInSet) io::writeTextFile(set.folder() / summary.filename(), summaryMarkdown(run));
        set.commit();
        spdlog::info("wrote {}, {} and {}", csvFile.string(), jsonFile.string(), plotFile.string());
    }
    if (!flags.summary.empty()) {
        if (!summaryInSet) {
            createOutputFolder(summaryDir, summaryFlag);
            io::writeTextFile(summary, summaryMarkdown(run));
        }
        spdlog::info("wrote {}", flags.summary);
    }
    printTable(run);

    return validationExitCode(context);
}

} // namespace

Command addBenchCommand(CLI::App& app, std::vector<std::string> commandLine)
{
    auto flags = std::make_shared<BenchFlags>();
    flags->command = std::move(commandLine);
    CLI::App* cmd = app.add_subcommand("bench", "Run a config's sweep (techniques x parameters x scenes x lights): "
                                                "GPU and CPU time per pass, memory per technique and each light's "
                                                "error against the reference technique; write CSV, JSON and a Pareto plot");
    cmd->add_option("config", flags->config, "Scene config (JSON) with a \"sweep\"")->required();
    cmd->add_option("-o,--output", flags->output,
                    "Write results.csv, results.json and pareto.svg into this folder (created if missing; other "
                    "files in it are left alone)");
    cmd->add_option("--summary", flags->summary, "Also write the results as a Markdown summary to this file");
    cmd->add_option("--frames", flags->frames, "Measured frames per variant (medians)")
        ->check(CLI::Range(1u, 100000u))
        ->capture_default_str();
    cmd->add_option("--warmup", flags->warmup, "Untimed frames before the measured ones, per variant")
        ->check(CLI::Range(0u, 100000u))
        ->capture_default_str();
    cmd->add_flag("--animate", flags->animate,
                  "Walk an animated config along its animation: frame k of each variant (warm-up frames first) is "
                  "posed at time k / fps, and the errors are over every measured frame, each against the reference "
                  "of its own pose (without: every frame shows frame 0)");
    addReferenceFlags(*cmd, flags->reference);
    addSizeFlags(*cmd, flags->run, "every variant");
    addParamOverrideFlag(*cmd, flags->run.settings);
    addAllowRootFlag(*cmd, flags->run.allowedRoots);
    addDeviceFlags(*cmd, flags->device);
    return {cmd, [flags] { return runBench(*flags); }};
}

} // namespace penumbra::app
