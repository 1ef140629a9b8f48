#include "visibility/ReceiverScatter.h"

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <thread>
#include <vector>

namespace penumbra::visibility {
namespace {

// receiver_scatter.comp's constants: how far the unprojected point may lie from the
// G-buffer's position of the same pixel, relative to the coordinates' size, and the
// depth ulps left below each receiver's depth.
constexpr float kReconstructionRelative = 1e-5f;
constexpr float kDepthUlps = 4.0f / 16777216.0f;

constexpr uint32_t kNone = 0xffffffffu;  // no receiver
// The scatter's threads: at most this many, each with at least kMinBandRows camera rows.
constexpr uint32_t kMaxScatterThreads = 8;
constexpr uint32_t kMinBandRows = 32;

// |grad (row . p / w)| at p, for a row of the light's matrix: (row w - x row_w) / w^2.
float projectedGradient(const glm::vec3& row, const glm::vec3& rowW, float x, float w)
{
    return glm::length(row * w - x * rowW) / (w * w);
}

glm::vec3 matrixRow(const glm::mat4& m, int r) { return {m[0][r], m[1][r], m[2][r]}; }

// The least value within `radius` of each of the `n` entries of a line (entry i at
// line[i * stride]), in place, with van Herk's and Gil and Werman's running minima over
// blocks of 2 radius + 1: the line padded with `radius` entries of kNone at each end,
// the window of entry i is [i, i + 2 radius] of the padded line, which is the suffix
// minimum of its block at i and the prefix minimum of the next block at i + 2 radius.
void minFilterLine(uint32_t* line, ptrdiff_t stride, uint32_t n, uint32_t radius, std::vector<uint32_t>& prefix,
                   std::vector<uint32_t>& suffix)
{
    const size_t padded = size_t(n) + 2 * size_t(radius), width = 2 * size_t(radius) + 1;
    prefix.resize(padded);
    suffix.resize(padded);
    const auto at = [&](size_t k) {
        return k < radius || k >= radius + n ? kNone : line[ptrdiff_t(k - radius) * stride];
    };
    for (size_t k = 0; k < padded; ++k) prefix[k] = k % width == 0 ? at(k) : std::min(prefix[k - 1], at(k));
    for (size_t k = padded; k-- > 0;)
        suffix[k] = k + 1 == padded || (k + 1) % width == 0 ? at(k) : std::min(suffix[k + 1], at(k));
    for (size_t i = 0; i < n; ++i) line[ptrdiff_t(i) * stride] = std::min(suffix[i], prefix[i + 2 * radius]);
}

// One camera row's receivers, computed branch-free over the row (so that the compiler
// vectorises it) into structure-of-arrays form; the scattered writes follow, pixel by
// pixel, for the receivers only.
struct RowReceivers {
    std::vector<int32_t> tx, ty;          // view texel (valid pixels only)
    std::vector<int32_t> x0, y0, x1, y1;  // the receiver depth's texels, inclusive
    std::vector<uint32_t> bits;           // the receiver depth's bits
    std::vector<int32_t> valid;           // a receiver in the view (1) or not (0)
    void resize(size_t n)
    {
        for (auto* v : {&tx, &ty, &x0, &y0, &x1, &y1}) v->resize(n);
        bits.resize(n);
        valid.resize(n);
    }
};

// The per-pixel arithmetic of receiver_scatter.comp over one row (see there for the
// reasoning), without a branch, so that it vectorises.
template <bool WithDepth>
[[gnu::always_inline]] inline void computeRow(const float* __restrict depthRow, const float* __restrict ndcX,
                                              uint32_t width, float ndcY, const glm::mat4 inverseViewProj,
                                              const glm::mat4 m, const glm::vec3 eye, int32_t resolution,
                                              int32_t* __restrict valid, int32_t* __restrict tx,
                                              int32_t* __restrict ty, uint32_t* __restrict bits,
                                              int32_t* __restrict x0, int32_t* __restrict y0,
                                              int32_t* __restrict x1, int32_t* __restrict y1)
{
    const float res = float(resolution), texelsPerNdc = 0.5f * res;
    const glm::vec3 rowX = matrixRow(m, 0), rowY = matrixRow(m, 1), rowZ = matrixRow(m, 2), rowW = matrixRow(m, 3);
    for (uint32_t x = 0; x < width; ++x) {
        const float depth = depthRow[x];
        const glm::vec4 world = inverseViewProj * glm::vec4(ndcX[x], ndcY, depth, 1.0f);
        const float ww = world.w != 0.0f ? world.w : 1.0f;
        const glm::vec3 p = glm::vec3(world) / ww;
        const glm::vec4 clip = m * glm::vec4(p, 1.0f);
        const float cw = clip.w > 0.0f ? clip.w : 1.0f;
        const glm::vec3 light = glm::vec3(clip) / cw;
        // Bitwise on ints: branch-free (&& would be a branch the vectoriser refuses), and a
        // NaN fails every test.
        const int inView = int(std::abs(light.x) <= 1.0f) & int(std::abs(light.y) <= 1.0f) & int(light.z >= 0.0f) &
                           int(light.z <= 1.0f);
        const bool receiver = (int(depth > 0.0f) & int(world.w != 0.0f) & int(clip.w > 0.0f) & inView) != 0;
        const float cx = (light.x * 0.5f + 0.5f) * res, cy = (light.y * 0.5f + 0.5f) * res;
        // GLSL's ivec2(float) truncates; inside the view the coordinate is >= 0 (and
        // outside it, the value is not used).
        const float lastTexel = res - 1.0f;
        // std::max(c, v) and std::min(c, v) with the constant first give the constant for a
        // NaN v: no NaN reaches a conversion to int (whose result would index anywhere).
        const auto clampTexel = [&](float v) { return int32_t(std::min(lastTexel, std::max(0.0f, v))); };
        valid[x] = receiver ? 1 : 0;
        tx[x] = clampTexel(receiver ? cx : 0.0f);
        ty[x] = clampTexel(receiver ? cy : 0.0f);
        if constexpr (WithDepth) {
            const float slack = kReconstructionRelative * (glm::length(p) + glm::length(p - eye));
            const float farthest = light.z - projectedGradient(rowZ, rowW, clip.z, cw) * slack - kDepthUlps;
            // A NaN depth becomes 0, the farthest: it keeps every caster.
            bits[x] = std::bit_cast<uint32_t>(std::max(0.0f, farthest));
            const float gradient =
                std::max(projectedGradient(rowX, rowW, clip.x, cw), projectedGradient(rowY, rowW, clip.y, cw));
            // At most a texel (receiver_scatter.comp); a NaN spread (an overflowing slack)
            // takes the whole texel too.
            const float spread = std::min(1.0f, texelsPerNdc * slack * gradient + 1.0f / 64.0f);
            const auto texelOf = [&](float c) { return clampTexel(std::floor(receiver ? c : 0.0f)); };
            x0[x] = texelOf(cx - spread);
            x1[x] = texelOf(cx + spread);
            y0[x] = texelOf(cy - spread);
            y1[x] = texelOf(cy + spread);
        }
    }
}

// Compiled also for AVX2, picked at run time: the rows are all float arithmetic. The
// arrays are distinct (restrict parameters: the compiler then needs no overlap checks).
#define PENUMBRA_ROW_ARGS                                                                                          \
    const float *__restrict depthRow, const float *__restrict ndcX, uint32_t width, float ndcY,                    \
        const glm::mat4 &inverseViewProj, const glm::mat4 &m, const glm::vec3 &eye, int32_t resolution,           \
        int32_t *__restrict valid, int32_t *__restrict tx, int32_t *__restrict ty, uint32_t *__restrict bits,     \
        int32_t *__restrict x0, int32_t *__restrict y0, int32_t *__restrict x1, int32_t *__restrict y1
#define PENUMBRA_ROW_CALL                                                                                          \
    depthRow, ndcX, width, ndcY, inverseViewProj, m, eye, resolution, valid, tx, ty, bits, x0, y0, x1, y1
__attribute__((target_clones("avx2", "default"))) void computeMarksRow(PENUMBRA_ROW_ARGS)
{
    computeRow<false>(PENUMBRA_ROW_CALL);
}
__attribute__((target_clones("avx2", "default"))) void computeDepthsRow(PENUMBRA_ROW_ARGS)
{
    computeRow<true>(PENUMBRA_ROW_CALL);
}
#undef PENUMBRA_ROW_CALL
#undef PENUMBRA_ROW_ARGS

// What every band of rows shares.
struct ScatterShared {
    const ScatterCamera& camera;
    const ScatterView& view;
    std::vector<uint32_t> maskOf;  // the mask texel of each view texel along an axis
    std::vector<float> ndcX;       // each column's x in normalised device coordinates
};

// Rows [y0, y1) of the camera: their arithmetic a row at a time (computeMarksRow or
// computeDepthsRow), then the writes. Bands run side by side and may meet at a texel:
// the marks are stored and the depths lowered atomically (relaxed: the host reads them
// once every band has been joined).
TexelBounds scatterBand(const ScatterShared& shared, uint32_t y0, uint32_t y1)
{
    const ScatterCamera& camera = shared.camera;
    const ScatterView& view = shared.view;
    const bool withDepth = !view.receiverDepth.empty();
    const size_t maskSize = view.maskSize, stride = view.resolution;
    uint32_t* marks = view.marks.data();
    uint32_t* depths = view.receiverDepth.data();
    TexelBounds written;
    RowReceivers row;
    row.resize(camera.width);
    // Neighbouring pixels often fall in the same texels (wherever a texel is larger than a
    // pixel): a pixel whose texels are the last receiver's, with a depth no nearer,
    // changes nothing and is skipped.
    int32_t lastX0 = -1, lastY0 = -1, lastX1 = -1, lastY1 = -1;
    uint32_t lastBits = 0;
    for (uint32_t y = y0; y < y1; ++y) {
        const float ndcY = (float(y) + 0.5f) / float(camera.height) * 2.0f - 1.0f;
        const float* depthRow = camera.depth.data() + size_t(y) * camera.width;
        (withDepth ? computeDepthsRow : computeMarksRow)(
            depthRow, shared.ndcX.data(), camera.width, ndcY, camera.inverseViewProj, view.lightViewProj, camera.eye,
            int32_t(view.resolution), row.valid.data(), row.tx.data(), row.ty.data(), row.bits.data(),
            row.x0.data(), row.y0.data(), row.x1.data(), row.y1.data());
        for (uint32_t x = 0; x < camera.width; ++x) {
            if (!row.valid[x]) continue;
            const size_t mark = shared.maskOf[uint32_t(row.ty[x])] * maskSize + shared.maskOf[uint32_t(row.tx[x])];
            std::atomic_ref<uint32_t>(marks[mark]).store(1u, std::memory_order_relaxed);
            if (!withDepth) continue;
            const uint32_t bits = row.bits[x];
            const int32_t x0 = row.x0[x], x1 = row.x1[x], ty0 = row.y0[x], ty1 = row.y1[x];
            if (x0 == lastX0 && ty0 == lastY0 && x1 == lastX1 && ty1 == lastY1 && bits >= lastBits) continue;
            lastX0 = x0, lastY0 = ty0, lastX1 = x1, lastY1 = ty1, lastBits = bits;
            for (int32_t ry = ty0; ry <= ty1; ++ry)
                for (int32_t rx = x0; rx <= x1; ++rx) {
                    std::atomic_ref<uint32_t> texel(depths[size_t(ry) * stride + size_t(rx)]);
                    uint32_t current = texel.load(std::memory_order_relaxed);
                    while (bits < current && !texel.compare_exchange_weak(current, bits, std::memory_order_relaxed)) {
                    }
                }
            written.x0 = std::min(written.x0, uint32_t(x0));
            written.y0 = std::min(written.y0, uint32_t(ty0));
            written.x1 = std::max(written.x1, uint32_t(x1));
            written.y1 = std::max(written.y1, uint32_t(ty1));
        }
    }
    return written;
}

} // namespace

TexelBounds scatterReceivers(const ScatterCamera& camera, const ScatterView& view)
{
    if (camera.width == 0 || camera.height == 0 || view.resolution == 0) return {};
    ScatterShared shared{camera, view, std::vector<uint32_t>(view.resolution), std::vector<float>(camera.width)};
    for (uint32_t t = 0; t < view.resolution; ++t) shared.maskOf[t] = t / view.block;
    for (uint32_t x = 0; x < camera.width; ++x)
        shared.ndcX[x] = (float(x) + 0.5f) / float(camera.width) * 2.0f - 1.0f;
    // One band of rows per core (the device is idle meanwhile: the build waits for this),
    // at least kMinBandRows rows each. The texels bands write are the same whatever the
    // split (a minimum is a minimum), so the result does not depend on the core count.
    const uint32_t cores = std::clamp(std::thread::hardware_concurrency(), 1u, kMaxScatterThreads);
    const uint32_t bands = std::clamp(camera.height / kMinBandRows, 1u, cores);
    std::vector<TexelBounds> written(bands);
    std::vector<std::thread> helpers;
    const auto band = [&](uint32_t b) {
        written[b] = scatterBand(shared, camera.height * b / bands, camera.height * (b + 1) / bands);
    };
    for (uint32_t b = 1; b < bands; ++b) helpers.emplace_back(band, b);
    band(0);
    for (std::thread& t : helpers) t.join();
    TexelBounds all;
    for (const TexelBounds& w : written) {
        if (w.empty()) continue;
        all.x0 = std::min(all.x0, w.x0), all.y0 = std::min(all.y0, w.y0);
        all.x1 = std::max(all.x1, w.x1), all.y1 = std::max(all.y1, w.y1);
    }
    return all;
}

void spreadReceiverDepth(std::span<uint32_t> depth, uint32_t size, uint32_t radius, const TexelBounds& written)
{
    if (written.empty() || radius == 0 || size == 0) return;
    // Rows with a depth, over the columns a depth can reach; then those columns over the
    // rows a depth can reach. Every other texel stays none, as the whole-view passes
    // leave it.
    const uint32_t x0 = written.x0 > radius ? written.x0 - radius : 0;
    const uint32_t x1 = std::min(written.x1 + radius, size - 1);
    const uint32_t y0 = written.y0 > radius ? written.y0 - radius : 0;
    const uint32_t y1 = std::min(written.y1 + radius, size - 1);
    std::vector<uint32_t> prefix, suffix;
    // Within a line, texels beyond [x0, x1] (or [y0, y1]) hold none: the line is cut there.
    for (uint32_t y = written.y0; y <= written.y1; ++y)
        minFilterLine(depth.data() + size_t(y) * size + x0, 1, x1 - x0 + 1, radius, prefix, suffix);
    for (uint32_t x = x0; x <= x1; ++x)
        minFilterLine(depth.data() + size_t(y0) * size + x, ptrdiff_t(size), y1 - y0 + 1, radius, prefix, suffix);
}

} // namespace penumbra::visibility
