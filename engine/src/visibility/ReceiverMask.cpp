#include "visibility/ReceiverMask.h"

#include "visibility/ReceiverScatter.h"

#include "penumbra/gpu/Barrier.h"
#include "penumbra/gpu/Context.h"
#include "penumbra/gpu/ShaderCompiler.h"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

namespace penumbra::visibility {
namespace {

constexpr VkFormat kMaskFormat = VK_FORMAT_R8_UNORM;

// Texels added to every view's footprint in the mask: the technique's lookup texel may
// round differently from the mask's (1), and receiver bias (normal offset, receiver
// plane) moves the lookup by up to about a texel (1).
constexpr float kMaskSafetyTexels = 2.0f;
// The receiver mask is kept at most this many texels per side: each mask texel stands for
// a block of the view's texels and is set when any texel of the block is. The queries
// still rasterise at the view's own resolution (so coverage is the technique's), and only
// their mask lookup is coarse: conservative, and it keeps the dilation's cost (serial
// sweeps per row and column) low. Measured on config/city-street.json (hard, 2048
// texels; `penumbra render --culling receiver-mask --stats`): 256 drew 32,930 caster
// triangles with 25 ms of masks, 512 drew 26,738 with 28 ms, 1024 25,810 with 40 ms,
// 2048 23,458 with 97 ms.
constexpr uint32_t kMaxMaskTexels = 512;

struct ScatterPush {  // receiver_scatter.comp Push
    glm::mat4 lightViewProj;
    int32_t maskBlock;
    int32_t resolution;
    int32_t maskSize;
};

struct CameraData {  // receiver_scatter.comp Camera
    glm::mat4 inverseViewProj;
    glm::vec4 size;
    glm::vec4 eye;
};

// The receiver floor's pyramid: a test reads at most this many cells per side.
constexpr uint32_t kFloorCellsPerSide = 8;
// Depth rounding between the CPU's box corners and the rasterizer's interpolated depth of
// the geometry inside (a few fp32 ulps of depths <= 1): 16 ulps of 1.
constexpr float kFloorMargin = 16.0f / 16777216.0f;

struct MaskTexelRange {
    uint32_t x0, y0, x1, y1;
};

// The mask texels a rectangle of view texels (inclusive) meets, inclusive, or nothing when
// it lies off the view.
std::optional<MaskTexelRange> maskTexels(const ReceiverMask& mask, const TexelRect& rect)
{
    const float blockTexels = float(mask.block), last = float(mask.size - 1);
    const float x0 = std::floor(rect.lo.x / blockTexels), y0 = std::floor(rect.lo.y / blockTexels);
    const float x1 = std::floor(rect.hi.x / blockTexels), y1 = std::floor(rect.hi.y / blockTexels);
    if (!(x1 >= 0.0f && y1 >= 0.0f && x0 <= last && y0 <= last)) return std::nullopt;
    return MaskTexelRange{uint32_t(std::max(x0, 0.0f)), uint32_t(std::max(y0, 0.0f)), uint32_t(std::min(x1, last)),
                          uint32_t(std::min(y1, last))};
}

// Back to all ones (no receiver) where the last build may have written a depth. The rows'
// spans are filled as few byte ranges: a range goes on over the gap to the next row's span
// when the gap is at most kFillGapBytes (the gap is all ones already, so filling it
// changes nothing), because on lavapipe each fill command costs about what a memset of
// some 10 KB does, and a 4096-texel map has 4096 rows.
constexpr VkDeviceSize kFillGapBytes = 16384;

void clearReceiverDepth(VkCommandBuffer cmd, const ReceiverMask& mask)
{
    const VkDeviceSize texel = sizeof(uint32_t), row = VkDeviceSize(mask.resolution) * texel;
    const VkBuffer buffer = mask.receiverDepth.handle();
    VkDeviceSize begin = 0, end = 0;  // the range being gathered; empty when begin == end
    const auto fill = [&] {
        if (begin < end) vkCmdFillBuffer(cmd, buffer, begin, end - begin, ~0u);
    };
    for (size_t y = 0; y < mask.receiverDepthWritten.size(); ++y) {
        const RowSpan span = mask.receiverDepthWritten[y];
        if (span.begin >= span.end) continue;
        const VkDeviceSize b = y * row + span.begin * texel, e = y * row + span.end * texel;
        if (begin < end && b <= end + kFillGapBytes) {
            end = e;
            continue;
        }
        fill();
        begin = b, end = e;
    }
    fill();
}

// Dilates `marked` (size x size words, 0 or not) by `radius` texels in a square neighbourhood
// into `dilated` (0 or 255): a pass along rows, then one along columns, each sweeping a
// line forwards and backwards with the distance to the nearest marked texel, so linear in
// the size whatever the radius.
void dilateMask(std::span<const uint32_t> marked, uint32_t size, uint32_t radius, std::vector<uint8_t>& dilated)
{
    std::vector<uint8_t> rows(marked.size());
    dilated.assign(marked.size(), 0);
    const auto sweep = [&](const auto* source, uint8_t* target, size_t line, size_t step) {
        // Texel i of the line is at line + i * step.
        int64_t last = INT64_MIN / 2;
        for (uint32_t i = 0; i < size; ++i) {
            if (source[line + i * step] != 0) last = i;
            target[line + i * step] = int64_t(i) - last <= int64_t(radius) ? 255 : 0;
        }
        int64_t next = INT64_MAX / 2;
        for (uint32_t i = size; i-- > 0;) {
            if (source[line + i * step] != 0) next = i;
            if (next - int64_t(i) <= int64_t(radius)) target[line + i * step] = 255;
        }
    };
    for (uint32_t y = 0; y < size; ++y) sweep(marked.data(), rows.data(), size_t(y) * size, 1);
    for (uint32_t x = 0; x < size; ++x) sweep(rows.data(), dilated.data(), x, size);
}

// Where a build may have written receiver depths: at the texels of the marked mask
// texels (the scatter marks the mask texel of every texel it writes), up to `margin`
// texels beside them (receiver_scatter.comp's spread, receiver_depth_min.comp's taps).
// The mask is dilated by at least that much already; the margin keeps this true for a
// view of any footprint.
std::vector<RowSpan> receiverDepthRows(const ReceiverMask& mask, uint32_t margin)
{
    const uint32_t size = mask.resolution, b = mask.block;
    std::vector<RowSpan> rows(size, RowSpan{size, 0});
    for (uint32_t my = 0; my < mask.size; ++my) {
        const RowSpan marked = mask.markedRows[my];
        if (marked.begin >= marked.end) continue;
        const uint32_t x0 = marked.begin * b > margin ? marked.begin * b - margin : 0;
        const uint32_t x1 = std::min(marked.end * b + margin, size);
        const uint32_t y0 = my * b > margin ? my * b - margin : 0;
        const uint32_t y1 = std::min((my + 1) * b + margin, size);
        for (uint32_t y = y0; y < y1; ++y) {
            rows[y].begin = std::min(rows[y].begin, x0);
            rows[y].end = std::max(rows[y].end, x1);
        }
    }
    return rows;
}

} // namespace

bool ReceiverMask::rejects(const TexelRect& rect) const
{
    const std::optional<MaskTexelRange> r = maskTexels(*this, rect);
    if (!r) return true;  // off the view
    const size_t w = size + 1;
    const size_t ix0 = r->x0, iy0 = r->y0, ix1 = size_t(r->x1) + 1, iy1 = size_t(r->y1) + 1;
    const uint64_t marked = uint64_t(summedArea[iy1 * w + ix1]) + summedArea[iy0 * w + ix0] -
                            summedArea[iy0 * w + ix1] - summedArea[iy1 * w + ix0];
    return marked == 0;
}

bool ReceiverMask::behindReceivers(const TexelRect& rect, float nearestDepth) const
{
    if (!hasReceiverDepth || floorLevels.empty()) return false;
    const std::optional<MaskTexelRange> r = maskTexels(*this, rect);
    if (!r) return true;  // off the view: no receiver reads it
    // The finest level at which the range spans at most kFloorCellsPerSide cells per side:
    // the least floor over those cells, a superset of the range, bounds it from below.
    uint32_t level = 0, x0 = r->x0, y0 = r->y0, x1 = r->x1, y1 = r->y1;
    while (level + 1 < floorLevels.size() && (x1 - x0 >= kFloorCellsPerSide || y1 - y0 >= kFloorCellsPerSide)) {
        ++level;
        x0 >>= 1, y0 >>= 1, x1 >>= 1, y1 >>= 1;
    }
    const uint32_t side = std::max((size + (1u << level) - 1) >> level, 1u);
    const std::vector<float>& cells = floorLevels[level];
    // Geometry inside the box lies at most at its nearest corner's depth (less its bias),
    // up to rounding: kFloorMargin.
    const float reach = nearestDepth + kFloorMargin;
    for (uint32_t y = y0; y <= y1; ++y)
        for (uint32_t x = x0; x <= x1; ++x)
            if (!(reach < cells[size_t(y) * side + x])) return false;
    return true;
}

ScatterPlacement scatterPlacementFor(const gpu::Context& context)
{
    const char* chosen = std::getenv(kScatterPlacementVariable);
    const std::string_view choice = chosen ? chosen : "";
    if (choice == "host") return ScatterPlacement::Host;
    if (choice == "device") return ScatterPlacement::Device;
    if (!choice.empty() && choice != "auto") {
        throw std::runtime_error(fmt::format("{}={}: expected host, device or auto (the default: host on a CPU "
                                             "device, device elsewhere)",
                                             kScatterPlacementVariable, choice));
    }
    return context.deviceInfo().type == "cpu" ? ScatterPlacement::Host : ScatterPlacement::Device;
}

ReceiverMaskBuilder::ReceiverMaskBuilder(gpu::Context& context, const gpu::ShaderCompiler& shaders,
                                         ScatterPlacement placement)
    : context_(context), placement_(placement)
{
    if (placement_ == ScatterPlacement::Host) return;
    gpu::ComputePipelineDesc c;
    c.name = "visibility.receiver_scatter";
    c.shader = "engine/receiver_scatter.comp";
    c.pushConstantBytes = sizeof(ScatterPush);
    scatter_ = gpu::Pipeline(context_, shaders, c);
    c.name = "visibility.receiver_depth_scatter";
    c.defines = {{"RECEIVER_DEPTH", "1"}};
    scatterDepth_ = gpu::Pipeline(context_, shaders, c);
    // The spreading over the taps, one axis per dispatch: push (size, radius, vertical).
    gpu::ComputePipelineDesc f;
    f.name = "visibility.receiver_depth_min";
    f.shader = "engine/receiver_depth_min.comp";
    f.pushConstantBytes = 3 * sizeof(int32_t);
    depthMin_ = gpu::Pipeline(context_, shaders, f);
    nearest_ = gpu::createSampler(context_, VK_FILTER_NEAREST, VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE);
    cameraData_ =
        gpu::Buffer(context_, sizeof(CameraData), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true, "visibility.camera");
}

void ReceiverMaskBuilder::setCamera(const gpu::Image& depth, const glm::mat4& viewProj, const glm::vec3& eye)
{
    cameraDepth_ = &depth;
    cameraInverseViewProj_ = glm::inverse(viewProj);
    cameraEye_ = eye;
    cameraDepthRead_ = false;
    if (placement_ == ScatterPlacement::Host) return;
    const CameraData data{cameraInverseViewProj_,
                          glm::vec4(float(depth.desc().width), float(depth.desc().height), 0.0f, 0.0f),
                          glm::vec4(eye, 0.0f)};
    std::memcpy(cameraData_.mapped(), &data, sizeof(data));
}

ReceiverMask& ReceiverMaskBuilder::maskFor(uint32_t resolution)
{
    const auto found = masks_.find(resolution);
    if (found != masks_.end()) return found->second;
    ReceiverMask& mask = masks_[resolution];
    mask.resolution = resolution;
    const std::string name = fmt::format("visibility.light{}", resolution);
    mask.block = (resolution + kMaxMaskTexels - 1) / kMaxMaskTexels;
    mask.size = (resolution + mask.block - 1) / mask.block;
    const uint32_t m = mask.size;
    // Host-visible: the host dilates the marks where the scatter wrote them.
    mask.marked = gpu::Buffer(context_, VkDeviceSize(m) * m * sizeof(uint32_t),
                              VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, true,
                              name + ".mask");
    mask.dilated = gpu::Image(context_, {m, m, kMaskFormat, VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT,
                                         name + ".mask_dilated"});
    mask.upload =
        gpu::Buffer(context_, VkDeviceSize(m) * m, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, true, name + ".mask_upload");
    context_.submitAndWait([&](VkCommandBuffer cmd) {
        gpu::transition(cmd, mask.dilated, gpu::access::kUndefined,
                        {VK_IMAGE_LAYOUT_GENERAL, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, 0});
    });
    return mask;
}

void ReceiverMaskBuilder::makeReceiverDepth(ReceiverMask& mask, bool withPrefix)
{
    const std::string name = fmt::format("visibility.light{}", mask.resolution);
    const VkDeviceSize depthBytes = VkDeviceSize(mask.resolution) * mask.resolution * sizeof(uint32_t);
    const VkBufferUsageFlags storage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    // Host-visible: the CPU culling and the receiver floor read the receiver depths where
    // they are written.
    if (!mask.receiverDepth.handle()) {
        mask.receiverDepth = gpu::Buffer(context_, depthBytes, storage, true, name + ".receiver_depth");
        std::memset(mask.receiverDepth.mapped(), 0xff, depthBytes);  // no receiver anywhere
        mask.receiverDepthWritten.clear();
    }
    if (withPrefix && placement_ == ScatterPlacement::Device && !mask.receiverDepthPrefix.handle())
        mask.receiverDepthPrefix = gpu::Buffer(context_, depthBytes, storage, false, name + ".receiver_depth_prefix");
}

const ReceiverMask& ReceiverMaskBuilder::build(const render::CasterView& view)
{
    ReceiverMask& mask = maskFor(view.resolution);
    mask.hasReceiverDepth = view.compareTapRadius >= 0;
    const int32_t tapRadius = std::min(view.compareTapRadius, int32_t(view.resolution));
    if (mask.hasReceiverDepth) makeReceiverDepth(mask, tapRadius > 0);
    if (placement_ == ScatterPlacement::Host)
        scatterOnHost(mask, view, tapRadius);
    else
        context_.submitAndWait([&](VkCommandBuffer cmd) { recordMask(cmd, mask, view, tapRadius); });
    // The reach in mask texels: a view texel within `reach` of a marked one lies in a mask
    // texel within ceil(reach / block) of the marked one's.
    const float reach = std::min(view.footprintTexels, float(view.resolution)) + kMaskSafetyTexels;
    const auto radius = uint32_t(std::min(std::ceil(std::max(reach, 0.0f) / float(mask.block)), float(mask.size)));
    // Dilated on the host: the mask is read back anyway, and lavapipe's serial sweeps
    // over a 512² image cost 10-16 ms of a street view's mask against about 2 ms here
    // (docs/culling.md).
    const size_t texels = size_t(mask.size) * mask.size;
    dilateMask({static_cast<const uint32_t*>(mask.marked.mapped()), texels}, mask.size, radius, mask.dilatedTexels);
    sumMarkedTexels(mask);
    if (mask.hasReceiverDepth) {
        mask.receiverDepthWritten = receiverDepthRows(mask, uint32_t(tapRadius) + 1);
        buildFloorPyramid(mask);
    } else {
        mask.floorLevels.clear();
        uploadDilated(mask);  // the queries test against it
    }
    return mask;
}

void ReceiverMaskBuilder::recordMask(VkCommandBuffer cmd, ReceiverMask& mask, const render::CasterView& view,
                                     int32_t tapRadius)
{
    const uint32_t size = view.resolution;
    const bool ownDepth = mask.hasReceiverDepth;

    // The previous submission's reads and writes of these images (the last view).
    gpu::memoryBarrier(cmd, {VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_WRITE_BIT},
                       {VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT});
    vkCmdFillBuffer(cmd, mask.marked.handle(), 0, VK_WHOLE_SIZE, 0u);
    if (ownDepth) clearReceiverDepth(cmd, mask);
    gpu::memoryBarrier(cmd, {VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_WRITE_BIT},
                       {VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT});
    // The texels the camera's pixels look up, and their depths (receiver_scatter.comp).
    const gpu::Pipeline& scatter = ownDepth ? scatterDepth_ : scatter_;
    scatter.bind(cmd);
    gpu::DescriptorPush scatterBindings;
    scatterBindings.sampledImage("cameraDepth", *cameraDepth_, nearest_, VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL)
        .storageBuffer("ReceiverMarks", mask.marked)
        .storageBuffer("camera", cameraData_);
    if (ownDepth) scatterBindings.storageBuffer("ReceiverDepth", mask.receiverDepth);
    scatterBindings.push(context_, cmd, scatter);
    const ScatterPush scatterPush{view.viewProj, int32_t(mask.block), int32_t(size), int32_t(mask.size)};
    scatter.pushConstants(cmd, &scatterPush, sizeof(scatterPush));
    scatter.dispatchOver(cmd, *cameraDepth_);

    const gpu::MemoryAccess stores{VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT};
    const gpu::MemoryAccess loads{VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_COPY_BIT,
                                  VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT |
                                      VK_ACCESS_2_TRANSFER_READ_BIT};
    gpu::memoryBarrier(cmd, stores, loads);
    if (ownDepth && tapRadius > 0) {
        // Each receiver's depth over the texels its taps read (receiver_depth_min.comp).
        depthMin_.bind(cmd);
        gpu::DescriptorPush()
            .storageBuffer("Depth", mask.receiverDepth)
            .storageBuffer("Prefix", mask.receiverDepthPrefix)
            .push(context_, cmd, depthMin_);
        for (int32_t vertical = 0; vertical < 2; ++vertical) {
            const int32_t push[3] = {int32_t(size), tapRadius, vertical};
            depthMin_.pushConstants(cmd, push, sizeof(push));
            depthMin_.dispatchOver(cmd, size);
            gpu::memoryBarrier(cmd, stores, loads);
        }
    }
    // The marks and the receiver depths, for the host.
    gpu::memoryBarrier(cmd, {VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT},
                       {VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT});
}

// The camera depth into a host-visible buffer kept across frames (a fresh one per frame
// cost its pages' first touch, a few ms for 1280 x 720 on lavapipe), as the floats the
// scatter reads: the depth is D32_SFLOAT, which a copy leaves as it is.
void ReceiverMaskBuilder::readCameraDepth()
{
    const gpu::ImageDesc& desc = cameraDepth_->desc();
    if (desc.format != VK_FORMAT_D32_SFLOAT) {
        throw std::logic_error(fmt::format("ReceiverMaskBuilder: the camera depth {} is not D32_SFLOAT", desc.name));
    }
    const VkDeviceSize bytes = VkDeviceSize(desc.width) * desc.height * sizeof(float);
    if (cameraDepthReadback_.size() != bytes) {
        cameraDepthReadback_ = gpu::Buffer(context_, bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT, true,
                                           "visibility.camera_depth_readback");
    }
    const gpu::ImageAccess sampled{VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                                   VK_ACCESS_2_MEMORY_WRITE_BIT};
    const gpu::ImageAccess copySource{VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, VK_PIPELINE_STAGE_2_COPY_BIT,
                                      VK_ACCESS_2_TRANSFER_READ_BIT};
    const gpu::ImageAccess back{VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                                VK_ACCESS_2_MEMORY_READ_BIT};
    context_.submitAndWait([&](VkCommandBuffer cmd) {
        gpu::transition(cmd, *cameraDepth_, sampled, copySource);
        VkBufferImageCopy copy{};
        copy.imageSubresource = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, 0, 1};
        copy.imageExtent = {desc.width, desc.height, 1};
        vkCmdCopyImageToBuffer(cmd, cameraDepth_->handle(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                               cameraDepthReadback_.handle(), 1, &copy);
        gpu::transition(cmd, *cameraDepth_, copySource, back);
        gpu::memoryBarrier(cmd, {VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT},
                           {VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT});
    });
    cameraDepthRead_ = true;
}

void ReceiverMaskBuilder::scatterOnHost(ReceiverMask& mask, const render::CasterView& view, int32_t tapRadius)
{
    if (!cameraDepthRead_) readCameraDepth();
    // As recordMask's clears: no marks; no receiver depth where the last build wrote one.
    const size_t maskTexels = size_t(mask.size) * mask.size;
    std::memset(mask.marked.mapped(), 0, maskTexels * sizeof(uint32_t));
    ScatterView target;
    target.lightViewProj = view.viewProj;
    target.resolution = view.resolution;
    target.block = mask.block;
    target.maskSize = mask.size;
    target.marks = {static_cast<uint32_t*>(mask.marked.mapped()), maskTexels};
    if (mask.hasReceiverDepth) {
        target.receiverDepth = {static_cast<uint32_t*>(mask.receiverDepth.mapped()),
                                size_t(view.resolution) * view.resolution};
        for (size_t y = 0; y < mask.receiverDepthWritten.size(); ++y) {
            const RowSpan span = mask.receiverDepthWritten[y];
            if (span.begin < span.end)
                std::fill(target.receiverDepth.begin() + ptrdiff_t(y * view.resolution + span.begin),
                          target.receiverDepth.begin() + ptrdiff_t(y * view.resolution + span.end), ~0u);
        }
    }
    const gpu::ImageDesc& depth = cameraDepth_->desc();
    const ScatterCamera camera{cameraInverseViewProj_, cameraEye_, depth.width, depth.height,
                               {static_cast<const float*>(cameraDepthReadback_.mapped()),
                                size_t(depth.width) * depth.height}};
    const TexelBounds written = scatterReceivers(camera, target);
    if (mask.hasReceiverDepth && tapRadius > 0)
        spreadReceiverDepth(target.receiverDepth, view.resolution, uint32_t(tapRadius), written);
}

void ReceiverMaskBuilder::uploadDilated(const ReceiverMask& mask)
{
    std::memcpy(mask.upload.mapped(), mask.dilatedTexels.data(), mask.dilatedTexels.size());
    context_.submitAndWait([&](VkCommandBuffer cmd) {
        // The host's write; the last queries' reads of the image were waited for.
        gpu::memoryBarrier(cmd, {VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_WRITE_BIT},
                           {VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_READ_BIT});
        const gpu::ImageAccess sampled{VK_IMAGE_LAYOUT_GENERAL, VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT,
                                       VK_ACCESS_2_SHADER_SAMPLED_READ_BIT};
        const gpu::ImageAccess copyTarget{VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_PIPELINE_STAGE_2_COPY_BIT,
                                          VK_ACCESS_2_TRANSFER_WRITE_BIT};
        VkBufferImageCopy copy{};
        copy.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        copy.imageExtent = {mask.size, mask.size, 1};
        gpu::transition(cmd, mask.dilated, sampled, copyTarget);
        vkCmdCopyBufferToImage(cmd, mask.upload.handle(), mask.dilated.handle(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                               1, &copy);
        gpu::transition(cmd, mask.dilated, copyTarget, sampled);
    });
}

// A summed-area table of the dilated mask (whether any texel of a rectangle is marked, in
// O(1)), and the bounds of the marked texels.
void ReceiverMaskBuilder::sumMarkedTexels(ReceiverMask& mask)
{
    const uint32_t m = mask.size;
    const uint8_t* texels = mask.dilatedTexels.data();
    mask.summedArea.assign(size_t(m + 1) * (m + 1), 0);
    mask.markedRows.assign(m, RowSpan{m, 0});
    uint32_t x0 = m, y0 = m, x1 = 0, y1 = 0;  // the marked texels' bounds, inclusive
    for (uint32_t y = 0; y < m; ++y) {
        uint32_t row = 0;
        for (uint32_t x = 0; x < m; ++x) {
            const bool marked = texels[size_t(y) * m + x] != 0;
            row += marked ? 1u : 0u;
            mask.summedArea[size_t(y + 1) * (m + 1) + x + 1] = mask.summedArea[size_t(y) * (m + 1) + x + 1] + row;
            if (marked) {
                mask.markedRows[y].begin = std::min(mask.markedRows[y].begin, x);
                mask.markedRows[y].end = x + 1;
                x0 = std::min(x0, x);
                x1 = std::max(x1, x);
                y0 = std::min(y0, y);
                y1 = std::max(y1, y);
            }
        }
    }
    // The queries render only there (render area and scissor; the viewport, and so every
    // texel centre, stays the view's): no sample outside it could pass the mask, and
    // lavapipe's cost per query grows with the area it bins, not only with what is drawn.
    // An empty mask keeps one texel: the traversal then rejects every node.
    if (x0 > x1) x0 = x1 = y0 = y1 = 0;
    const uint32_t b = mask.block, size = mask.resolution;
    mask.bounds = {{int32_t(x0 * b), int32_t(y0 * b)},
                   {std::min((x1 + 1) * b, size) - x0 * b, std::min((y1 + 1) * b, size) - y0 * b}};
}

std::vector<std::vector<float>> floorPyramid(std::span<const uint32_t> floorBits, uint32_t size)
{
    std::vector<std::vector<float>> levels;
    std::vector<float> level(size_t(size) * size);
    for (size_t i = 0; i < level.size(); ++i)
        level[i] = floorBits[i] == ~0u ? std::numeric_limits<float>::infinity() : std::bit_cast<float>(floorBits[i]);
    levels.push_back(std::move(level));
    for (uint32_t side = size; side > 1;) {
        const uint32_t next = (side + 1) / 2;
        const std::vector<float>& fine = levels.back();
        std::vector<float> coarse(size_t(next) * next, std::numeric_limits<float>::infinity());
        for (uint32_t y = 0; y < side; ++y)
            for (uint32_t x = 0; x < side; ++x) {
                float& cell = coarse[size_t(y / 2) * next + x / 2];
                cell = std::min(cell, fine[size_t(y) * side + x]);
            }
        levels.push_back(std::move(coarse));
        side = next;
    }
    return levels;
}

void ReceiverMaskBuilder::buildFloorPyramid(ReceiverMask& mask)
{
    // The receiver floor: per mask texel of the dilated mask, the least receiver depth over
    // the block of view texels it stands for (after the spreading over the taps); none
    // (all ones) elsewhere.
    const uint32_t m = mask.size, b = mask.block, size = mask.resolution;
    std::vector<uint32_t> floorBits(size_t(m) * m, ~0u);
    for (uint32_t my = 0; my < m; ++my) {
        const RowSpan marked = mask.markedRows[my];
        for (uint32_t mx = marked.begin; mx < marked.end; ++mx) {
            if (mask.dilatedTexels[size_t(my) * m + mx] == 0) continue;
            uint32_t least = ~0u;
            for (uint32_t y = my * b; y < std::min((my + 1) * b, size); ++y)
                for (uint32_t x = mx * b; x < std::min((mx + 1) * b, size); ++x)
                    least = std::min(least, mask.receiverDepthBits(x, y));
            floorBits[size_t(my) * m + mx] = least;
        }
    }
    mask.floorLevels = floorPyramid(floorBits, m);
}

} // namespace penumbra::visibility
