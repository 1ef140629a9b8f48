// The reference technique (README.md next to this file): exact area-light visibility by
// ray tracing with Embree on the CPU. Per frame, inside the frame's render graph: a
// compute pass copies the G-buffer's positions and normals into host-visible buffers, a
// host pass traces stratified shadow rays from every pixel's surface point to the light
// (or takes V from the disk cache), and a compute pass writes V into V_l (upload.comp).
#include "LightSampling.h"
#include "RasterReference.h"
#include "ReferenceStats.h"
#include "SceneTracer.h"
#include "VisibilityCache.h"

#include "penumbra/core/Digest.h"
#include "penumbra/core/Error.h"
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/gpu/Resources.h"
#include "penumbra/graph/PassContext.h"
#include "penumbra/graph/RenderGraph.h"
#include "penumbra/plugin/GBuffer.h"
#include "penumbra/plugin/Plugin.h"
#include "penumbra/plugin/Progress.h"
#include "penumbra/plugin/Technique.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>
#include <iterator>
#include <limits>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace penumbra::reference {
namespace {

using plugin::ParamType;

// Two ways to the same V: shadow rays traced on the CPU (this file), and the average of
// hard shadow maps rendered from light samples on the GPU (RasterReference.h).
enum class Mode : uint32_t { RayTraced, BruteForce };
const char* const kModeNames[] = {"ray_traced", "brute_force"};

const plugin::ParamSpec kParams[] = {
    {"mode", ParamType::Enum, double(Mode::RayTraced), 0, 0, "",
     "ray_traced: Embree shadow rays from every pixel to stratified points of the light; brute_force: N hard shadow "
     "maps from the light samples, averaged: the rasterised reference of the papers",
     kModeNames, uint32_t(std::size(kModeNames))},
    {"samples", ParamType::Int, 256, 1, 65536, "rays/pixel",
     "light samples per pixel, stratified (correlated multi-jittered); brute_force: shadow maps, at most 4096; "
     "lights without extent take 1"},
    {"seed", ParamType::Int, 1, 0, 2147483647, "",
     "jitter of the sample patterns; the same seed gives a bit-identical image on any thread count"},
    {"cache", ParamType::Bool, 1, 0, 1, "",
     "reuse V from the disk cache ($PENUMBRA_CACHE_DIR, else $XDG_CACHE_HOME/penumbra, else ~/.cache/penumbra) "
     "when scene, G-buffer, light and parameters are unchanged"},
    {"threads", ParamType::Int, 0, 0, 1024, "", "tracing threads; 0: one per hardware thread"},
    {"map_resolution", ParamType::Int, 512, 16, 8192, "texels",
     "brute_force: texels per side of each face of each sample's shadow map (point, rect, disk and sphere lights: "
     "six faces in a 3 x 2 atlas); brute_force is not cached (cache and threads do not apply)"},
};

// The version of what a cached image means: raise it whenever the tracing changes the
// values it produces, so that old files stop matching.
constexpr char kAlgorithmVersion[] = "penumbra-reference ray_traced 3";

// Shadow rays start off the receiver along its normal by this many times the bound on
// the G-buffer position's distance from the true surface (gbufferPositionError, which
// GBufferExport hands over in the normal's w: 5e-7 of the point's distance from the eye
// plus its own magnitude, measured at most 0.4 of it). Four bounds clear the surface
// and Embree's own rounding (a few ulps of the coordinates) at any scale, and are the
// least the position allows: the origin's lift shifts a contact shadow by lift / gap of
// its width (README.md, "Numerical care"). Before, 1e-5 of the scene's radius plus the
// point's largest coordinate: 15 % of a 1 mm gap under a 20 m ground.
constexpr float kRayOffsetBounds = 4.0f;
// Crossings of one surface closer than this (relative to the scene's radius plus the
// point's largest coordinate) count once: Embree may report a hit twice (shared edges,
// spatial splits). Far above the hits' rounding, far below any two real surfaces.
constexpr float kSameSurfaceRelative = 1e-5f;

struct Settings {
    Mode mode = Mode::RayTraced;
    uint32_t samples = 256;
    uint32_t seed = 1;
    bool cache = true;
    uint32_t threads = 0;
    uint32_t mapResolution = 512;
};

Settings readSettings(const plugin::ParamValues& params)
{
    Settings s;
    s.mode = Mode(params.getEnumIndex("mode"));
    s.samples = uint32_t(params.getInt("samples"));
    s.seed = uint32_t(params.getInt("seed"));
    s.cache = params.getBool("cache");
    s.threads = uint32_t(params.getInt("threads"));
    s.mapResolution = uint32_t(params.getInt("map_resolution"));
    return s;
}

std::atomic<uint64_t> gFramesTraced{0}, gRaysTraced{0}, gCacheHits{0}, gCacheRejected{0}, gCacheWrites{0};

// Shows how far tracing is, on stderr, when stderr is a terminal (never in logs or
// pipes). Redraws one line from the thread that waits for the tracers.
class ProgressLine {
public:
    ProgressLine(std::string label, uint32_t total)
        : label_(std::move(label)), total_(total), shown_(isatty(fileno(stderr)) != 0),
          start_(std::chrono::steady_clock::now())
    {}
    bool shown() const { return shown_; }
    void draw(uint32_t done) const
    {
        constexpr int kWidth = 30;
        const double fraction = total_ > 0 ? double(done) / double(total_) : 1.0;
        const double elapsedS = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
        const int filled = int(fraction * kWidth);
        std::string eta = "";
        if (fraction > 0.0 && fraction < 1.0) eta = fmt::format(", {:.0f} s left", elapsedS * (1.0 - fraction) / fraction);
        fmt::print(stderr, "\r{}: tracing [{}{}] {:3.0f}%{}   ", label_, std::string(size_t(filled), '#'),
                   std::string(size_t(kWidth - filled), ' '), 100.0 * fraction, eta);
        std::fflush(stderr);
    }
    void finish() const
    {
        draw(total_);
        fmt::print(stderr, "\n");
    }

private:
    std::string label_;
    uint32_t total_;
    bool shown_;
    std::chrono::steady_clock::time_point start_;
};

gpu::ComputePipelineDesc uploadPipeline()
{
    gpu::ComputePipelineDesc desc;
    desc.name = "reference.upload";
    desc.shader = "upload.comp";
    return desc;
}

class ReferenceShadow final : public plugin::Technique {
public:
    explicit ReferenceShadow(const plugin::TechniqueSetup& setup)
        : settings_(readSettings(setup.params)),
          lightIndex_(setup.lightIndex),
          width_(setup.width),
          height_(setup.height),
          light_(setup.light),
          sampler_(setup.light),
          tracer_(setup.scene),
          cache_(defaultCacheFolder()),
          gbufferExport_(setup.context, setup.shaders),
          upload_(setup.context, setup.shaders, uploadPipeline())
    {
        if (settings_.cache && cache_.folder().empty())
            spdlog::warn("reference (light {}): no cache folder: set PENUMBRA_CACHE_DIR (or XDG_CACHE_HOME or HOME); "
                         "every frame is traced",
                         lightIndex_);
    }

    void update(const scene::Light& light, const scene::Aabb&) override
    {
        light_ = light;
        sampler_ = LightSampler(light);
    }

    void instancesMoved(std::span<const uint32_t> instances) override { tracer_.refit(instances); }

    void registerPasses(graph::RenderGraph& graph, const plugin::LightPassIo& io) override
    {
        const VkDeviceSize pixels = VkDeviceSize(width_) * height_;
        const std::string positions = io.local("positions"), normals = io.local("normals"),
                          visibility = io.local("visibility_host");
        graph.declareBuffer({positions, pixels * plugin::GBufferExport::kTexelBytes});
        graph.declareBuffer({normals, pixels * plugin::GBufferExport::kTexelBytes});
        graph.declareBuffer({visibility, pixels * sizeof(float)});
        gbufferExport_.addPass(graph, io.local("read_gbuffer"), io.gbuffer, positions, normals);
        std::string label = io.prefix;
        if (!label.empty() && label.back() == '.') label.pop_back();
        graph.addPass(io.local("trace"), graph::QueueKind::Host)
            .read(positions, graph::Usage::HostRead)
            .read(normals, graph::Usage::HostRead)
            .write(visibility, graph::Usage::HostWrite)
            .execute([=, this](graph::PassContext& pass) {
                computeVisibility(pass.hostMemory(positions), pass.hostMemory(normals), pass.hostMemory(visibility),
                                  label);
            });
        graph.addPass(io.local("upload"), graph::QueueKind::Compute)
            .read(visibility, graph::Usage::Storage)
            .write(io.visibility, graph::Usage::Storage)
            .execute([=, this](graph::PassContext& pass) {
                const gpu::Image& image = pass.image(io.visibility);
                upload_.bind(pass.cmd());
                gpu::DescriptorPush()
                    .storageBuffer("Traced", pass.buffer(visibility))
                    .storageImage("visibilityOut", image)
                    .push(pass.context(), pass.cmd(), upload_);
                upload_.dispatchOver(pass.cmd(), image);
            });
    }

private:
    // Everything V depends on: the algorithm, the scene's shadow-casting geometry, the
    // light's shape and placement (not its colour or intensity), the parameters that
    // change values (not `cache` or `threads`), and the G-buffer, which holds the camera.
    CacheKey cacheKey(std::span<const std::byte> positions, std::span<const std::byte> normals) const
    {
        core::Digest128 digest;
        digest.bytes(kAlgorithmVersion, sizeof kAlgorithmVersion)
            .value(tracer_.geometryDigest())
            .value(light_.type)
            .value(light_.position)
            .value(light_.direction)
            .value(light_.tangent)
            .value(light_.angularDiameterDeg)
            .value(light_.sizeWorld)
            .value(light_.radiusWorld)
            .value(settings_.mode)
            .value(settings_.samples)
            .value(settings_.seed)
            .value(width_)
            .value(height_)
            .bytes(positions.data(), positions.size())
            .bytes(normals.data(), normals.size());
        return digest.finish();
    }

    void computeVisibility(std::span<const std::byte> positions, std::span<const std::byte> normals,
                           std::span<std::byte> out, const std::string& label)
    {
        const size_t pixels = size_t(width_) * height_;
        std::optional<CacheKey> key;
        if (settings_.cache) {
            key = cacheKey(positions, normals);
            if (const std::vector<float>* cached = findCached(*key)) {
                std::memcpy(out.data(), cached->data(), pixels * sizeof(float));
                ++gCacheHits;
                return;
            }
        }
        std::vector<float> values = trace(positions, normals, label);
        std::memcpy(out.data(), values.data(), pixels * sizeof(float));
        if (key) remember(*key, std::move(values));
    }

    // The last frame's image when nothing changed since (an unanimated run of many
    // frames), else a valid file of the disk cache.
    const std::vector<float>* findCached(const CacheKey& key)
    {
        if (lastKey_ == key) return &last_;
        if (cache_.folder().empty()) return nullptr;
        VisibilityCache::Lookup lookup = cache_.load(key, width_, height_);
        if (!lookup.rejected.empty()) {
            ++gCacheRejected;
            spdlog::warn("reference (light {}): ignoring the cache file {}; tracing again", lightIndex_,
                         lookup.rejected);
        }
        if (!lookup.values) return nullptr;
        lastKey_ = key;
        last_ = std::move(*lookup.values);
        return &last_;
    }

    void remember(const CacheKey& key, std::vector<float> values)
    {
        lastKey_ = key;
        last_ = std::move(values);
        if (cache_.folder().empty()) return;
        try {
            cache_.store(key, width_, height_, last_);
            ++gCacheWrites;
        } catch (const Error& e) {
            // The image is right; only the saving failed. Say so once per technique.
            if (!storeWarned_) spdlog::warn("reference (light {}): {}; results are not cached", lightIndex_, e.what());
            storeWarned_ = true;
        }
    }

    std::vector<float> trace(std::span<const std::byte> positionBytes, std::span<const std::byte> normalBytes,
                             const std::string& label) const
    {
        const auto* positions = reinterpret_cast<const float*>(positionBytes.data());
        const auto* normals = reinterpret_cast<const float*>(normalBytes.data());
        std::vector<float> values(size_t(width_) * height_);
        const uint32_t threads =
            std::max(1u, settings_.threads > 0 ? settings_.threads : std::thread::hardware_concurrency());
        const uint32_t count = sampler_.sampleCount(settings_.samples);
        std::atomic<uint32_t> nextRow{0}, rowsDone{0};
        std::atomic<uint64_t> rays{0};
        std::exception_ptr failure;
        std::mutex failureMutex;

        // Rows are handed out one at a time; every pixel's value depends only on its own
        // samples (seeded by seed and pixel), so the split does not change a bit.
        const auto work = [&] {
            try {
                const DenormalsAreZero denormals;
                RayScratch scratch;
                uint64_t traced = 0;
                for (uint32_t y; (y = nextRow++) < height_; ++rowsDone)
                    for (uint32_t x = 0; x < width_; ++x) {
                        const size_t i = size_t(y) * width_ + x;
                        values[i] = tracePixel(i, &positions[4 * i], &normals[4 * i], count, scratch, traced);
                    }
                rays += traced;
            } catch (...) {
                const std::lock_guard lock(failureMutex);
                if (!failure) failure = std::current_exception();
                nextRow = height_;  // the others stop at their next row
            }
        };
        const ProgressLine progress(label, height_);
        // Rows done, on the terminal and to a waiting viewer (plugin/Progress.h).
        const bool wanted = plugin::progressWanted();
        plugin::startProgress();
        std::vector<std::thread> pool;
        for (uint32_t t = 0; t < threads; ++t) pool.emplace_back(work);
        bool cancelled = false;
        if (progress.shown() || wanted) {
            while (rowsDone.load() < height_ && !failure) {
                if (progress.shown()) progress.draw(rowsDone.load());
                plugin::reportProgress(rowsDone.load(), height_);
                // Whoever waits gave up on the frame: the tracers stop after their row.
                if (plugin::progressCancelled()) {
                    cancelled = true;
                    nextRow = height_;
                    break;
                }
                std::this_thread::sleep_for(std::chrono::milliseconds(progress.shown() ? 200 : 50));
            }
        }
        for (std::thread& t : pool) t.join();
        if (failure) std::rethrow_exception(failure);
        if (cancelled) {
            throw Error(fmt::format("reference (light {}): tracing cancelled at row {} of {}", lightIndex_, rowsDone.load(),
                                    height_));
        }
        plugin::reportProgress(height_, height_);
        if (progress.shown()) progress.finish();
        ++gFramesTraced;
        gRaysTraced += rays.load();
        return values;
    }

    // V of one pixel: the mean transmittance of its stratified samples, in [0, 1].
    float tracePixel(size_t pixel, const float* position, const float* normalWorld, uint32_t count,
                     RayScratch& scratch, uint64_t& traced) const
    {
        if (position[3] == 0.0f) return 1.0f;  // no geometry: VISIBILITY_NO_GEOMETRY
        const glm::vec3 p(position[0], position[1], position[2]);
        if (!(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z))) return 1.0f;
        const glm::vec3 n(normalWorld[0], normalWorld[1], normalWorld[2]);
        const float nLength = glm::length(n);
        const glm::vec3 pAbs = glm::abs(p);
        const float sameSurface = kSameSurfaceRelative * (tracer_.sceneRadius() + std::max({pAbs.x, pAbs.y, pAbs.z}));
        // The position's error bound; a point without one (not finite, not positive) falls
        // back to the same-surface distance, which bounds it from above at any scale.
        const float bound = normalWorld[3];
        const float offset = std::isfinite(bound) && bound > 0.0f ? std::min(kRayOffsetBounds * bound, sameSurface)
                                                                  : sameSurface;
        // Off the surface on the side the camera sees (the G-buffer's normal faces it).
        // Without a usable normal, each ray starts `offset` along itself instead.
        const bool hasNormal = std::isfinite(nLength) && nLength > 0.5f;
        const glm::vec3 origin = hasNormal ? p + (offset / nLength) * n : p;
        const uint32_t pattern = mixBits(uint32_t(pixel) ^ mixBits(settings_.seed + 0x9e3779b9u));
        // The horizon test's normal, and the offset origin's lift off the surface: the
        // tangent plane is p's, not the origin's.
        const glm::dvec3 normal(n), lift(origin - p);
        double sum = 0.0;
        for (uint32_t s = 0; s < count; ++s) {
            const ShadowRay ray = sampler_.sample(glm::dvec3(origin), stratifiedSample(s, count, pattern));
            // Stop short of the light sample by the same-surface distance: a caster touching
            // the light does not count, and nothing at the sample itself is hit.
            const double length = ray.length - double(sameSurface);
            if (!(length > 0.0)) {
                sum += 1.0;
                continue;
            }
            const glm::vec3 dir(ray.direction);
            // Below the surface's tangent plane through p (not through the offset origin):
            // the surface itself blocks the sample (shaders/common/visibility.glsl).
            if (hasNormal) {
                const double above = std::isinf(ray.length) ? glm::dot(normal, ray.direction)
                                                            : glm::dot(normal, lift + ray.direction * ray.length);
                if (!(above > 0.0)) continue;
            }
            const glm::vec3 start = hasNormal ? origin : origin + offset * dir;
            sum += double(tracer_.transmittance(start, dir, std::isinf(length) ? std::numeric_limits<float>::infinity()
                                                                                : float(length),
                                                sameSurface, scratch));
            ++traced;
        }
        const float v = float(sum / double(count));
        return v >= 0.0f ? std::min(v, 1.0f) : 0.0f;  // sanitizeVisibility (shaders/common/visibility.glsl)
    }

    const Settings settings_;
    const uint32_t lightIndex_;
    const uint32_t width_;
    const uint32_t height_;
    scene::Light light_;
    LightSampler sampler_;
    SceneTracer tracer_;
    VisibilityCache cache_;
    plugin::GBufferExport gbufferExport_;  // the G-buffer as floats for the tracer
    gpu::Pipeline upload_;                 // upload.comp: the traced V into V_l
    std::optional<CacheKey> lastKey_;
    std::vector<float> last_;
    bool storeWarned_ = false;
};

plugin::Technique* createReferenceShadow(const plugin::TechniqueSetup& setup)
{
    const Settings settings = readSettings(setup.params);
    if (settings.mode == Mode::BruteForce)
        return new RasterReference(setup, {settings.samples, settings.seed, settings.mapResolution});
    return new ReferenceShadow(setup);
}

} // namespace
} // namespace penumbra::reference

PENUMBRA_DEFINE_PLUGIN_FACTORY("reference", "1.0.0",
                               "exact area-light visibility: stratified shadow rays traced with Embree on the CPU, "
                               "translucent casters included, cached on disk; or (mode brute_force) the mean of hard "
                               "shadow maps from light samples on the GPU",
                               penumbra::reference::kParams, &penumbra::reference::createReferenceShadow)

PENUMBRA_PLUGIN_EXPORT PenumbraReferenceStats penumbra_reference_stats()
{
    using namespace penumbra::reference;
    return {gFramesTraced.load(), gRaysTraced.load(), gCacheHits.load(), gCacheRejected.load(), gCacheWrites.load()};
}
