#include "ComparisonWorker.h"

#include "penumbra/core/Error.h"
#include "penumbra/frame/FrameRenderer.h"
#include "penumbra/plugin/PluginRegistry.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <memory>

namespace penumbra::viewer {

ComparisonWorker::ComparisonWorker(gpu::ContextOptions options, std::vector<std::filesystem::path> pluginSearchPath)
    : options_(std::move(options)), pluginSearchPath_(std::move(pluginSearchPath))
{
    options_.presentation.reset();  // B is read back, never shown through a swapchain of its own
    thread_ = std::thread([this] { run(); });
}

ComparisonWorker::~ComparisonWorker()
{
    {
        std::lock_guard<std::mutex> lock(mutex_);
        stop_ = true;
        waiting_.reset();
        progress_.cancelled = true;
    }
    wake_.notify_all();
    thread_.join();
}

void ComparisonWorker::request(ComparisonRequest request)
{
    {
        std::lock_guard<std::mutex> lock(mutex_);
        waiting_ = std::move(request);
        busy_ = true;
    }
    wake_.notify_all();
}

void ComparisonWorker::cancel()
{
    std::lock_guard<std::mutex> lock(mutex_);
    waiting_.reset();
    done_.reset();
    ++generation_;
    progress_.cancelled = true;  // a pass that polls (the reference's tracing) stops at its next row
}

DrawerProgress ComparisonWorker::progress() const
{
    DrawerProgress p;
    p.busy = busy_;
    if (!p.busy) return p;
    const int64_t now = std::chrono::steady_clock::now().time_since_epoch().count();
    p.seconds = double(now - startedNs_.load()) * 1e-9;
    p.passes = progress_.passes.load();
    p.fraction = progress_.fraction.load();
    return p;
}

std::optional<ComparisonResult> ComparisonWorker::take()
{
    std::lock_guard<std::mutex> lock(mutex_);
    std::optional<ComparisonResult> out = std::move(done_);
    done_.reset();
    return out;
}

void ComparisonWorker::run()
{
    // The worker's own device, registry and scene: nothing of the window's is touched
    // from this thread.
    std::unique_ptr<gpu::Context> context;
    std::unique_ptr<plugin::PluginRegistry> plugins;
    std::unique_ptr<scene::Scene> scene;
    std::string sceneKey;
    const plugin::ProgressScope progress(progress_);
    for (;;) {
        ComparisonRequest request;
        uint64_t generation = 0;
        {
            std::unique_lock<std::mutex> lock(mutex_);
            wake_.wait(lock, [&] { return stop_ || waiting_.has_value(); });
            if (stop_) break;
            request = std::move(*waiting_);
            waiting_.reset();
            generation = generation_;
            startedNs_ = std::chrono::steady_clock::now().time_since_epoch().count();
            progress_.passes = 0;
            progress_.fraction = 0.0;
            progress_.cancelled = false;
        }
        ComparisonResult result;
        result.viewKey = request.viewKey;
        const auto start = std::chrono::steady_clock::now();
        try {
            if (!context) context = std::make_unique<gpu::Context>(options_);
            if (!plugins) plugins = std::make_unique<plugin::PluginRegistry>(pluginSearchPath_);
            // The scene is built again only when its source changed.
            const std::string key = config::configJson(request.config, "/")["scene"].dump();
            if (!scene || key != sceneKey) {
                scene.reset();
                config::RenderConfig c = request.config;
                scene = std::make_unique<scene::Scene>(config::buildScene(c.scene));
                sceneKey = key;
            }
            // Posed as A is (the animation starts from the rest pose at every request).
            config::RenderConfig posed = request.config;
            if (config::animated(request.config)) config::poseScene(request.config, request.timeS, posed, *scene);
            frame::FrameRenderer renderer(*context, *scene, posed, *plugins);
            renderer.renderFrame();
            result.images = app::captureFrame(renderer);
        } catch (const std::exception& e) {
            result.error = e.what();
        }
        if (context) validationMessages_ = context->validationMessageCount();
        result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        std::lock_guard<std::mutex> lock(mutex_);
        if (generation == generation_) done_ = std::move(result);
        busy_ = waiting_.has_value();
    }
}

} // namespace penumbra::viewer
