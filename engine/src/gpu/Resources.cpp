#include "penumbra/gpu/Resources.h"

#include "penumbra/core/Error.h"
#include "penumbra/gpu/Barrier.h"
#include "penumbra/gpu/Check.h"
#include "penumbra/gpu/Context.h"

#include <fmt/format.h>
#include <glm/gtc/packing.hpp>

#include <cstring>
#include <utility>

namespace penumbra::gpu {

Buffer::Buffer(Context& context, VkDeviceSize size, VkBufferUsageFlags usage, bool hostVisible,
               const std::string& name)
    : device_(context.device()), size_(size)
{
    createHandle(context, usage, name);
    const VkMemoryRequirements req = memoryRequirements();
    VkMemoryAllocateInfo alloc{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
    alloc.allocationSize = req.size;
    alloc.memoryTypeIndex = hostVisible
        ? context.findMemoryType(req.memoryTypeBits,
                                 VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT,
                                 VK_MEMORY_PROPERTY_HOST_CACHED_BIT)
        : context.findMemoryType(req.memoryTypeBits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    try {
        memory_ = context.allocateMemory(alloc, fmt::format("buffer '{}' ({} bytes)", name, uint64_t(size)),
                                         "lower what sets its size");
        check(vkBindBufferMemory(device_, buffer_, memory_, 0), "vkBindBufferMemory " + name);
        if (hostVisible) {
            check(vkMapMemory(device_, memory_, 0, VK_WHOLE_SIZE, 0, &mapped_), "vkMapMemory " + name);
        }
    } catch (...) {
        release();
        throw;
    }
}

Buffer Buffer::createUnbound(Context& context, VkDeviceSize size, VkBufferUsageFlags usage, const std::string& name)
{
    Buffer buffer;
    buffer.device_ = context.device();
    buffer.size_ = size;
    buffer.createHandle(context, usage, name);
    return buffer;
}

void Buffer::createHandle(Context& context, VkBufferUsageFlags usage, const std::string& name)
{
    if (size_ == 0) {
        throw GpuError(fmt::format("buffer '{}': size 0", name));
    }
    VkBufferCreateInfo info{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
    info.size = size_;
    info.usage = usage;
    info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    check(vkCreateBuffer(device_, &info, nullptr, &buffer_), "vkCreateBuffer " + name);
    context.setName(VK_OBJECT_TYPE_BUFFER, reinterpret_cast<uint64_t>(buffer_), name);
}

VkMemoryRequirements Buffer::memoryRequirements() const
{
    VkMemoryRequirements req{};
    vkGetBufferMemoryRequirements(device_, buffer_, &req);
    return req;
}

void Buffer::bindMemory(VkDeviceMemory memory, VkDeviceSize offset)
{
    check(vkBindBufferMemory(device_, buffer_, memory, offset), "vkBindBufferMemory");
}

Buffer::~Buffer() { release(); }

Buffer::Buffer(Buffer&& other) noexcept { *this = std::move(other); }

Buffer& Buffer::operator=(Buffer&& other) noexcept
{
    if (this != &other) {
        release();
        device_ = std::exchange(other.device_, VK_NULL_HANDLE);
        buffer_ = std::exchange(other.buffer_, VK_NULL_HANDLE);
        memory_ = std::exchange(other.memory_, VK_NULL_HANDLE);
        size_ = std::exchange(other.size_, 0);
        mapped_ = std::exchange(other.mapped_, nullptr);
    }
    return *this;
}

void Buffer::release()
{
    if (!device_) {
        return;
    }
    if (buffer_) vkDestroyBuffer(device_, buffer_, nullptr);
    if (memory_) vkFreeMemory(device_, memory_, nullptr);
    buffer_ = VK_NULL_HANDLE;
    memory_ = VK_NULL_HANDLE;
    mapped_ = nullptr;
    device_ = VK_NULL_HANDLE;
}

bool isDepthFormat(VkFormat format)
{
    return format == VK_FORMAT_D32_SFLOAT || format == VK_FORMAT_D16_UNORM ||
           format == VK_FORMAT_X8_D24_UNORM_PACK32 || format == VK_FORMAT_D24_UNORM_S8_UINT ||
           format == VK_FORMAT_D32_SFLOAT_S8_UINT;
}

uint32_t channelCount(VkFormat format)
{
    switch (format) {
    case VK_FORMAT_R16G16_SNORM:
    case VK_FORMAT_R32G32_SFLOAT: return 2;
    case VK_FORMAT_R8G8B8A8_UNORM:
    case VK_FORMAT_R8G8B8A8_SRGB:
    case VK_FORMAT_R16G16B16A16_SFLOAT:
    case VK_FORMAT_R32G32B32A32_UINT:
    case VK_FORMAT_R32G32B32A32_SFLOAT: return 4;
    default: return 1;
    }
}

uint32_t texelSize(VkFormat format)
{
    switch (format) {
    case VK_FORMAT_R8_UNORM: return 1;
    case VK_FORMAT_R8G8B8A8_UNORM:
    case VK_FORMAT_R8G8B8A8_SRGB:
    case VK_FORMAT_R16G16_SNORM:
    case VK_FORMAT_R32_SFLOAT:
    case VK_FORMAT_D32_SFLOAT:
    case VK_FORMAT_R32_UINT: return 4;
    case VK_FORMAT_R16_SFLOAT:
    case VK_FORMAT_R16_UNORM: return 2;
    case VK_FORMAT_R16G16B16A16_SFLOAT:
    case VK_FORMAT_R32G32_SFLOAT: return 8;
    case VK_FORMAT_R32G32B32A32_UINT:
    case VK_FORMAT_R32G32B32A32_SFLOAT: return 16;
    default: throw GpuError(fmt::format("texelSize: format {} is not supported for read-back",
                                        static_cast<int>(format)));
    }
}

std::string describe(const ImageDesc& desc)
{
    const std::string layers = desc.layers > 1 ? fmt::format(" x {} layers", desc.layers) : "";
    return fmt::format("image '{}' ({} x {}{} {})", desc.name, desc.width, desc.height, layers, formatName(desc.format));
}

namespace {

// An image used only for copies (a transfer source or destination) may have no view:
// Vulkan forbids one (VUID-VkImageViewCreateInfo-image-04441).
bool hasViewUsage(VkImageUsageFlags usage)
{
    constexpr VkImageUsageFlags kViewUsages = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_STORAGE_BIT |
                                              VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT |
                                              VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT |
                                              VK_IMAGE_USAGE_TRANSIENT_ATTACHMENT_BIT |
                                              VK_IMAGE_USAGE_INPUT_ATTACHMENT_BIT;
    return (usage & kViewUsages) != 0;
}

} // namespace

Image::Image(Context& context, const ImageDesc& desc) : device_(context.device()), desc_(desc)
{
    createHandle(context);
    try {
        const VkMemoryRequirements req = memoryRequirements();
        VkMemoryAllocateInfo alloc{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
        alloc.allocationSize = req.size;
        alloc.memoryTypeIndex = context.findMemoryType(req.memoryTypeBits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
        memory_ = context.allocateMemory(alloc, describe(desc), "lower the resolution or output size that sets its size");
        memorySize_ = req.size;
        check(vkBindImageMemory(device_, image_, memory_, 0), "vkBindImageMemory " + desc.name);
        if (hasViewUsage(desc_.usage)) createView();
    } catch (...) {
        release();
        throw;
    }
}

Image Image::createUnbound(Context& context, const ImageDesc& desc)
{
    Image image;
    image.device_ = context.device();
    image.desc_ = desc;
    image.createHandle(context);
    return image;
}

void Image::createHandle(Context& context)
{
    if (desc_.width == 0 || desc_.height == 0) {
        throw GpuError(fmt::format("image '{}': size {}x{} is empty", desc_.name, desc_.width, desc_.height));
    }
    const uint32_t maxDim = context.properties().limits.maxImageDimension2D;
    if (desc_.width > maxDim || desc_.height > maxDim) {
        throw GpuError(fmt::format("image '{}': size {}x{} exceeds the device limit {}", desc_.name, desc_.width,
                                   desc_.height, maxDim));
    }
    const uint32_t maxLayers = context.properties().limits.maxImageArrayLayers;
    if (desc_.layers == 0 || desc_.layers > maxLayers) {
        throw GpuError(fmt::format("image '{}': {} array layers, the device allows 1 to {}", desc_.name,
                                   desc_.layers, maxLayers));
    }
    VkImageCreateInfo info{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
    info.imageType = VK_IMAGE_TYPE_2D;
    info.format = desc_.format;
    info.extent = {desc_.width, desc_.height, 1};
    info.mipLevels = 1;
    info.arrayLayers = desc_.layers;
    info.samples = VK_SAMPLE_COUNT_1_BIT;
    info.tiling = VK_IMAGE_TILING_OPTIMAL;
    info.usage = desc_.usage;
    info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    check(vkCreateImage(device_, &info, nullptr, &image_), "vkCreateImage " + desc_.name);
    context.setName(VK_OBJECT_TYPE_IMAGE, reinterpret_cast<uint64_t>(image_), desc_.name);
}

void Image::createView()
{
    VkImageViewCreateInfo viewInfo{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
    viewInfo.image = image_;
    viewInfo.viewType = desc_.layers > 1 ? VK_IMAGE_VIEW_TYPE_2D_ARRAY : VK_IMAGE_VIEW_TYPE_2D;
    viewInfo.format = desc_.format;
    viewInfo.subresourceRange = {aspect(), 0, 1, 0, desc_.layers};
    check(vkCreateImageView(device_, &viewInfo, nullptr, &view_), "vkCreateImageView " + desc_.name);
}

VkMemoryRequirements Image::memoryRequirements() const
{
    VkMemoryRequirements req{};
    vkGetImageMemoryRequirements(device_, image_, &req);
    return req;
}

void Image::bindMemory(VkDeviceMemory memory, VkDeviceSize offset)
{
    check(vkBindImageMemory(device_, image_, memory, offset), "vkBindImageMemory " + desc_.name);
    memorySize_ = memoryRequirements().size;
    // A view needs a usage that views serve (VUID-VkImageViewCreateInfo-image-04441): a
    // render graph transient used only by copies and clears has none, and no view.
    if (hasViewUsage(desc_.usage)) createView();
}

Image::~Image() { release(); }

Image::Image(Image&& other) noexcept { *this = std::move(other); }

Image& Image::operator=(Image&& other) noexcept
{
    if (this != &other) {
        release();
        device_ = std::exchange(other.device_, VK_NULL_HANDLE);
        image_ = std::exchange(other.image_, VK_NULL_HANDLE);
        view_ = std::exchange(other.view_, VK_NULL_HANDLE);
        memory_ = std::exchange(other.memory_, VK_NULL_HANDLE);
        memorySize_ = std::exchange(other.memorySize_, 0);
        desc_ = std::move(other.desc_);
    }
    return *this;
}

void Image::release()
{
    if (!device_) {
        return;
    }
    if (view_) vkDestroyImageView(device_, view_, nullptr);
    if (image_) vkDestroyImage(device_, image_, nullptr);
    if (memory_) vkFreeMemory(device_, memory_, nullptr);
    view_ = VK_NULL_HANDLE;
    image_ = VK_NULL_HANDLE;
    memory_ = VK_NULL_HANDLE;
    device_ = VK_NULL_HANDLE;
}

VkImageAspectFlags Image::aspect() const
{
    return isDepthFormat(desc_.format) ? VK_IMAGE_ASPECT_DEPTH_BIT : VK_IMAGE_ASPECT_COLOR_BIT;
}

Buffer uploadBuffer(Context& context, std::span<const std::byte> bytes, VkBufferUsageFlags usage,
                    const std::string& name)
{
    Buffer buffer(context, bytes.size(), usage | VK_BUFFER_USAGE_TRANSFER_DST_BIT, false, name);
    updateBuffer(context, buffer, bytes);
    return buffer;
}

void updateBuffer(Context& context, const Buffer& buffer, std::span<const std::byte> bytes, Buffer* staging)
{
    if (bytes.size() > buffer.size()) {
        throw GpuError(fmt::format("updateBuffer: {} bytes do not fit a {}-byte buffer", bytes.size(), buffer.size()));
    }
    Buffer local;
    Buffer& source = staging ? *staging : local;
    if (!source.mapped() || source.size() < bytes.size()) {
        source = Buffer(context, bytes.size(), VK_BUFFER_USAGE_TRANSFER_SRC_BIT, true, "staging");
    }
    std::memcpy(source.mapped(), bytes.data(), bytes.size());
    context.submitAndWait([&](VkCommandBuffer cmd) {
        VkBufferCopy region{0, 0, bytes.size()};
        vkCmdCopyBuffer(cmd, source.handle(), buffer.handle(), 1, &region);
        memoryBarrier(cmd, {VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT},
                      {VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_READ_BIT});
    });
}

Image uploadImage(Context& context, uint32_t width, uint32_t height, VkFormat format, std::span<const std::byte> texels,
                  const std::string& name)
{
    Image image(context, {width, height, format, VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT, name});
    const VkDeviceSize size = VkDeviceSize(width) * height * texelSize(format);
    if (texels.size() != size) {
        throw GpuError(fmt::format("image '{}': {} bytes of texels for {}x{}, expected {}", name, texels.size(), width,
                                   height, size));
    }
    Buffer staging(context, size, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, true, name + " (staging)");
    std::memcpy(staging.mapped(), texels.data(), size);
    const ImageAccess copyTarget{VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_PIPELINE_STAGE_2_COPY_BIT,
                                 VK_ACCESS_2_TRANSFER_WRITE_BIT};
    const ImageAccess sampled{VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                              VK_ACCESS_2_SHADER_SAMPLED_READ_BIT};
    context.submitAndWait([&](VkCommandBuffer cmd) {
        transition(cmd, image, access::kUndefined, copyTarget);
        VkBufferImageCopy region{};
        region.imageSubresource = {image.aspect(), 0, 0, 1};
        region.imageExtent = {width, height, 1};
        vkCmdCopyBufferToImage(cmd, staging.handle(), image.handle(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
        transition(cmd, image, copyTarget, sampled);
    });
    return image;
}

std::vector<std::byte> readImage(Context& context, const Image& image, VkImageLayout layout)
{
    return readImage(context, image, layout, VkRect2D{{0, 0}, {image.desc().width, image.desc().height}});
}

std::vector<std::byte> readImage(Context& context, const Image& image, VkImageLayout layout, const VkRect2D& region)
{
    const ImageDesc& desc = image.desc();
    const bool inside = region.offset.x >= 0 && region.offset.y >= 0 && region.extent.width > 0 &&
                        region.extent.height > 0 && uint64_t(region.offset.x) + region.extent.width <= desc.width &&
                        uint64_t(region.offset.y) + region.extent.height <= desc.height;
    if (!inside) {
        throw GpuError(fmt::format("readImage: the rectangle ({}, {}) {} x {} is not inside {}", region.offset.x,
                                   region.offset.y, region.extent.width, region.extent.height, describe(desc)));
    }
    const VkDeviceSize size = VkDeviceSize(region.extent.width) * region.extent.height * texelSize(desc.format);
    Buffer staging(context, size, VK_BUFFER_USAGE_TRANSFER_DST_BIT, true, desc.name + " (read-back)");
    // `layout` with any earlier access -> copy source -> back to `layout`; the copy's
    // writes are made visible to the host.
    const ImageAccess before{layout, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_WRITE_BIT};
    const ImageAccess copySource{VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, VK_PIPELINE_STAGE_2_COPY_BIT,
                                 VK_ACCESS_2_TRANSFER_READ_BIT};
    const ImageAccess after{layout, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                            VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT};
    context.submitAndWait([&](VkCommandBuffer cmd) {
        transition(cmd, image, before, copySource);
        VkBufferImageCopy copy{};
        copy.imageSubresource = {image.aspect(), 0, 0, 1};
        copy.imageOffset = {region.offset.x, region.offset.y, 0};
        copy.imageExtent = {region.extent.width, region.extent.height, 1};
        vkCmdCopyImageToBuffer(cmd, image.handle(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, staging.handle(), 1, &copy);
        transition(cmd, image, copySource, after);
        memoryBarrier(cmd, {VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT},
                      {VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT});
    });
    std::vector<std::byte> out(size);
    std::memcpy(out.data(), staging.mapped(), size);
    return out;
}

namespace {

// Texels as readImageFloats gives them, from the bytes readImage gave.
std::vector<float> texelsAsFloats(const Image& image, const std::vector<std::byte>& bytes)
{
    const VkFormat format = image.desc().format;
    if (format == VK_FORMAT_R16_SFLOAT || format == VK_FORMAT_R16G16B16A16_SFLOAT) {
        std::vector<uint16_t> halves(bytes.size() / sizeof(uint16_t));
        std::memcpy(halves.data(), bytes.data(), halves.size() * sizeof(uint16_t));
        std::vector<float> out(halves.size());
        for (size_t i = 0; i < halves.size(); ++i) out[i] = glm::unpackHalf1x16(halves[i]);
        return out;
    }
    if (format == VK_FORMAT_R16_UNORM) {
        std::vector<uint16_t> values(bytes.size() / sizeof(uint16_t));
        std::memcpy(values.data(), bytes.data(), values.size() * sizeof(uint16_t));
        std::vector<float> out(values.size());
        for (size_t i = 0; i < values.size(); ++i) out[i] = float(values[i]) / 65535.0f;
        return out;
    }
    if (format == VK_FORMAT_R8_UNORM || format == VK_FORMAT_R8G8B8A8_UNORM || format == VK_FORMAT_R8G8B8A8_SRGB) {
        // The stored bytes over 255 (an sRGB image's encoded values, not decoded).
        std::vector<float> out(bytes.size());
        for (size_t i = 0; i < bytes.size(); ++i) out[i] = float(std::to_integer<uint8_t>(bytes[i])) / 255.0f;
        return out;
    }
    if (format == VK_FORMAT_R16G16_SNORM) {
        std::vector<int16_t> values(bytes.size() / sizeof(int16_t));
        std::memcpy(values.data(), bytes.data(), values.size() * sizeof(int16_t));
        std::vector<float> out(values.size());
        for (size_t i = 0; i < values.size(); ++i) out[i] = std::max(float(values[i]) / 32767.0f, -1.0f);
        return out;
    }
    if (format == VK_FORMAT_R32_UINT || format == VK_FORMAT_R32G32B32A32_UINT) {
        std::vector<uint32_t> values(bytes.size() / sizeof(uint32_t));
        std::memcpy(values.data(), bytes.data(), values.size() * sizeof(uint32_t));
        return std::vector<float>(values.begin(), values.end());
    }
    std::vector<float> out(bytes.size() / sizeof(float));
    std::memcpy(out.data(), bytes.data(), out.size() * sizeof(float));
    return out;
}

void expectNumbers(const Image& image)
{
    switch (image.desc().format) {
    case VK_FORMAT_R16_SFLOAT:
    case VK_FORMAT_R16G16B16A16_SFLOAT:
    case VK_FORMAT_R16_UNORM:
    case VK_FORMAT_R8_UNORM:
    case VK_FORMAT_R8G8B8A8_UNORM:
    case VK_FORMAT_R8G8B8A8_SRGB:
    case VK_FORMAT_R16G16_SNORM:
    case VK_FORMAT_R32_UINT:
    case VK_FORMAT_R32G32B32A32_UINT:
    case VK_FORMAT_R32_SFLOAT:
    case VK_FORMAT_R32G32B32A32_SFLOAT:
    case VK_FORMAT_D32_SFLOAT:
    case VK_FORMAT_R32G32_SFLOAT:
        return;
    default:
        throw GpuError(fmt::format("readImageFloats: image '{}' has format {}, which is not read back as numbers",
                                   image.desc().name, formatName(image.desc().format)));
    }
}

} // namespace

std::vector<float> readImageFloats(Context& context, const Image& image, VkImageLayout layout)
{
    expectNumbers(image);
    return texelsAsFloats(image, readImage(context, image, layout));
}

std::vector<float> readImageFloats(Context& context, const Image& image, VkImageLayout layout, const VkRect2D& region)
{
    expectNumbers(image);
    return texelsAsFloats(image, readImage(context, image, layout, region));
}

} // namespace penumbra::gpu
