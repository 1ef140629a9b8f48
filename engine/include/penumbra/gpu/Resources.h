#pragma once
// GPU buffers and images with their memory: one allocation per resource, or (created
// unbound) placed by their caller in memory it owns — the pass scheduler (graph module)
// aliases transient resources that way.
#include <vulkan/vulkan.h>

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace penumbra::gpu {

class Context;

class Buffer {
public:
    Buffer() = default;
    // Host-visible buffers are persistently mapped (mapped() != nullptr).
    Buffer(Context& context, VkDeviceSize size, VkBufferUsageFlags usage, bool hostVisible,
           const std::string& name);
    ~Buffer();
    Buffer(Buffer&& other) noexcept;
    Buffer& operator=(Buffer&& other) noexcept;
    Buffer(const Buffer&) = delete;
    Buffer& operator=(const Buffer&) = delete;

    // A buffer without memory: bind it with bindMemory() before use. The memory stays its
    // caller's (it may hold other resources at other times); the buffer never maps it.
    static Buffer createUnbound(Context& context, VkDeviceSize size, VkBufferUsageFlags usage,
                                const std::string& name);
    VkMemoryRequirements memoryRequirements() const;
    void bindMemory(VkDeviceMemory memory, VkDeviceSize offset);

    VkBuffer handle() const { return buffer_; }
    VkDeviceSize size() const { return size_; }
    void* mapped() const { return mapped_; }

private:
    void createHandle(Context& context, VkBufferUsageFlags usage, const std::string& name);
    void release();
    VkDevice device_ = VK_NULL_HANDLE;
    VkBuffer buffer_ = VK_NULL_HANDLE;
    VkDeviceMemory memory_ = VK_NULL_HANDLE;
    VkDeviceSize size_ = 0;
    void* mapped_ = nullptr;
};

struct ImageDesc {
    uint32_t width = 1;
    uint32_t height = 1;
    VkFormat format = VK_FORMAT_R8G8B8A8_UNORM;
    VkImageUsageFlags usage = 0;
    std::string name;
    // Array layers: more than one makes the view a 2-D array (GLSL image2DArray /
    // sampler2DArray), each layer as large as the device's largest 2-D image.
    uint32_t layers = 1;
};
// "image 'name' (W x H FORMAT)", with "x L layers" for an array: how messages name an image.
std::string describe(const ImageDesc& desc);

class Image {
public:
    Image() = default;
    Image(Context& context, const ImageDesc& desc);
    ~Image();
    Image(Image&& other) noexcept;
    Image& operator=(Image&& other) noexcept;
    Image(const Image&) = delete;
    Image& operator=(const Image&) = delete;

    // An image without memory (and without a view until bound): bind it with
    // bindMemory() before use. The memory stays its caller's, as for Buffer.
    static Image createUnbound(Context& context, const ImageDesc& desc);
    VkMemoryRequirements memoryRequirements() const;
    // Binds and creates the view (none when the usage allows no view: transfer only, as
    // for an image made with memory by the constructor).
    void bindMemory(VkDeviceMemory memory, VkDeviceSize offset);

    VkImage handle() const { return image_; }
    VkImageView view() const { return view_; }
    const ImageDesc& desc() const { return desc_; }
    VkImageAspectFlags aspect() const;
    VkDeviceSize memorySize() const { return memorySize_; }

private:
    void createHandle(Context& context);
    void createView();
    void release();
    VkDevice device_ = VK_NULL_HANDLE;
    VkImage image_ = VK_NULL_HANDLE;
    VkImageView view_ = VK_NULL_HANDLE;
    VkDeviceMemory memory_ = VK_NULL_HANDLE;
    VkDeviceSize memorySize_ = 0;
    ImageDesc desc_;
};

bool isDepthFormat(VkFormat format);
// Bytes per texel of the formats the engine reads back.
uint32_t texelSize(VkFormat format);
// Components per texel as readImageFloats returns them (1 for depth and single-channel formats).
uint32_t channelCount(VkFormat format);

// Creates a device-local buffer filled with `bytes` (through a staging copy).
Buffer uploadBuffer(Context& context, std::span<const std::byte> bytes, VkBufferUsageFlags usage,
                    const std::string& name);

// Overwrites the start of a device-local buffer (created with TRANSFER_DST usage, as
// uploadBuffer's are) with `bytes`, through a staging copy; waits for it. `staging`, when
// given, is a host-visible TRANSFER_SRC buffer kept by a caller that updates every frame
// (it is grown when too small), so that no allocation happens per update.
void updateBuffer(Context& context, const Buffer& buffer, std::span<const std::byte> bytes, Buffer* staging = nullptr);

// Creates a sampled 2D image filled with `texels` (tightly packed rows), left in
// SHADER_READ_ONLY_OPTIMAL.
Image uploadImage(Context& context, uint32_t width, uint32_t height, VkFormat format, std::span<const std::byte> texels,
                  const std::string& name);

// Copies a whole 2D image (in `layout`, left in that layout) into host memory, rows
// tightly packed. Used for PNG output and for tests.
std::vector<std::byte> readImage(Context& context, const Image& image, VkImageLayout layout);

// Same, as floats: one per channel (channelCount: R32F gives one per texel, RGBA16F and
// RGBA32F four); half floats are widened, unorm values divided by 255 or 65535 (an sRGB
// image's stored bytes, not decoded), RG16 snorm by 32767, unsigned integers converted.
std::vector<float> readImageFloats(Context& context, const Image& image, VkImageLayout layout);

// The same for a rectangle of the image (a pixel inspector's one texel), rows tightly
// packed; a rectangle not inside the image is a GpuError naming both.
std::vector<std::byte> readImage(Context& context, const Image& image, VkImageLayout layout, const VkRect2D& region);
std::vector<float> readImageFloats(Context& context, const Image& image, VkImageLayout layout, const VkRect2D& region);

} // namespace penumbra::gpu
