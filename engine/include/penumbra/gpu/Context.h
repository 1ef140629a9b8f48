#pragma once
// The Vulkan 1.3 instance, the chosen physical device, the logical device and its one
// queue. Headless by default: no surface extension is needed to render to a PNG; a window
// (the viewer) asks for presentation (ContextOptions::presentation).
#include <vulkan/vulkan.h>

#include <atomic>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra::gpu {

struct DeviceRequest {
    // Case-insensitive substring of the device name ("llvmpipe", "NVIDIA"); empty = any.
    std::string nameContains;
    // "discrete", "integrated", "virtual", "cpu" or empty for any.
    std::string type;
};

// True in Debug builds of the engine: validation is on by default there.
bool validationByDefault();

// What a window system needs of the context: its instance extensions (GLFW's
// glfwGetRequiredInstanceExtensions) and a test of whether a queue family of a device can
// present to it (glfwGetPhysicalDevicePresentationSupport). The engine then takes only a
// device with VK_KHR_swapchain whose one queue can present, and enables the extension.
struct Presentation {
    std::vector<std::string> instanceExtensions;
    std::function<bool(VkInstance, VkPhysicalDevice, uint32_t queueFamily)> canPresent;
};

struct ContextOptions {
    DeviceRequest device;
    // Loads VK_LAYER_KHRONOS_validation with synchronization validation and counts
    // every warning or error it reports (see Context::validationMessageCount).
    bool validation = validationByDefault();
    // How long one submission may run before submitAndWait calls it a hang (a GpuError,
    // never a hang of the process). Far above any frame this engine renders, even on a CPU
    // rasterizer; sanitizer runs, which slow the driver's own memory calls, raise it
    // (CMakePresets.json's sanitizer test presets).
    double submitTimeoutSeconds = 60.0;
    // Submit every render graph pass on its own and wait for it (PENUMBRA_ISOLATE_PASSES=1):
    // slow, but a lost device or a hang then names the one pass that caused it.
    bool isolatePasses = false;
    std::optional<Presentation> presentation;  // none: headless
};

// Reads PENUMBRA_DEVICE ("name" or "type:cpu"), PENUMBRA_VALIDATION (0/1),
// PENUMBRA_ISOLATE_PASSES (0/1) and PENUMBRA_GPU_TIMEOUT_S (seconds, > 0: submitTimeoutSeconds) so that a flag is not the
// only way to set them; explicit device fields in `base` win. Throws penumbra::ConfigError
// naming PENUMBRA_GPU_TIMEOUT_S when it is not a number in (0, 1e6].
ContextOptions contextOptionsFromEnvironment(ContextOptions base);

// Validation messages reported to every Context of this process, including those during
// a Context's destruction (objects still alive at vkDestroyDevice), which no Context
// outlives to count.
uint64_t validationMessagesInProcess();

// Failures of the device on demand, for tests: each hook returns the VkResult that the
// call reports instead of calling Vulkan, or VK_SUCCESS to let the call through. `what`
// says what the memory is for (Context::allocateMemory's description).
struct FaultHooks {
    std::function<VkResult(VkDeviceSize bytes, std::string_view what)> allocate;  // before each vkAllocateMemory
    std::function<VkResult()> submit;                                             // before each vkQueueSubmit2
};

struct DeviceInfo {
    std::string name;
    std::string type;  // "discrete", "integrated", "virtual", "cpu", "other"
    uint32_t apiVersion = 0;
    std::string driverInfo;
};

class Context {
public:
    explicit Context(const ContextOptions& options);
    ~Context();
    Context(const Context&) = delete;
    Context& operator=(const Context&) = delete;

    VkInstance instance() const { return instance_; }
    VkPhysicalDevice physicalDevice() const { return physicalDevice_; }
    VkDevice device() const { return device_; }
    VkQueue queue() const { return queue_; }
    uint32_t queueFamily() const { return queueFamily_; }
    const DeviceInfo& deviceInfo() const { return info_; }
    const VkPhysicalDeviceProperties& properties() const { return properties_; }
    const VkPhysicalDeviceMemoryProperties& memoryProperties() const { return memoryProperties_; }
    // The largest single allocation (Vulkan 1.1 maintenance3): what one resource may take
    // even where its sides fit the image limits (lavapipe: 2 GiB).
    VkDeviceSize maxMemoryAllocationSize() const { return maxMemoryAllocationSize_; }
    bool validationEnabled() const { return validation_; }
    bool isolatePasses() const { return isolatePasses_; }
    // Created with ContextOptions::presentation: VK_KHR_swapchain is enabled and the queue presents.
    bool presents() const { return presents_; }
    // The core features the device was created with (the optional ones where it has them).
    const VkPhysicalDeviceFeatures& enabledFeatures() const { return enabledFeatures_; }

    // Warnings and errors reported by the validation layer since creation.
    uint32_t validationMessageCount() const { return validationMessages_.load(); }
    // The first few messages, for a test to print when the count is not zero.
    std::vector<std::string> validationMessages() const;

    // Index of a memory type allowed by typeBits with all `required` flags, preferring
    // one that also has `preferred`. Throws GpuError when none fits.
    uint32_t findMemoryType(uint32_t typeBits, VkMemoryPropertyFlags required,
                            VkMemoryPropertyFlags preferred = 0) const;

    // vkAllocateMemory, through the fault hook. Out of device or host memory is a
    // GpuError that names `what` ("image 'pcss/depth' (16384 x 16384 D32_SFLOAT)"), how
    // many MiB it asked for of which heap, and `lower`: what the user can lower for it.
    VkDeviceMemory allocateMemory(const VkMemoryAllocateInfo& info, std::string_view what, std::string_view lower);

    // Tests: make the next allocations or submissions fail (FaultHooks). Empty hooks
    // switch injection off.
    void setFaultHooks(FaultHooks hooks) { faultHooks_ = std::move(hooks); }

    // Records commands into a one-time command buffer, submits and waits for them.
    void submitAndWait(const std::function<void(VkCommandBuffer)>& record);
    // Submits an already recorded command buffer and waits for it (at most 60 s).
    void submitAndWait(VkCommandBuffer cmd);

    // Debug label for a Vulkan object (VK_EXT_debug_utils, when validation is on).
    void setName(VkObjectType type, uint64_t handle, const std::string& name) const;
    void beginLabel(VkCommandBuffer cmd, const std::string& name) const;
    void endLabel(VkCommandBuffer cmd) const;

    VkCommandPool commandPool() const { return commandPool_; }

    // vkCmdPushDescriptorSetKHR (an extension entry point, loaded at device creation).
    void pushDescriptorSet(VkCommandBuffer cmd, VkPipelineBindPoint bindPoint, VkPipelineLayout layout,
                           const std::vector<VkWriteDescriptorSet>& writes) const;

    // Every physical device the loader reports, for error messages and `--list-devices`.
    static std::vector<DeviceInfo> listDevices();

private:
    static VKAPI_ATTR VkBool32 VKAPI_CALL onDebugMessage(
        VkDebugUtilsMessageSeverityFlagBitsEXT severity, VkDebugUtilsMessageTypeFlagsEXT types,
        const VkDebugUtilsMessengerCallbackDataEXT* data, void* self);

    void createInstance(bool validation, const std::vector<std::string>& extraExtensions);
    void selectPhysicalDevice(const DeviceRequest& request);
    void createDevice();
    // The queue family with graphics, compute and timestamps (and presentation when asked
    // for) of `device`; none when it has no such family.
    std::optional<uint32_t> queueFamilyOf(VkPhysicalDevice device) const;
    void destroy();

    VkInstance instance_ = VK_NULL_HANDLE;
    VkDebugUtilsMessengerEXT messenger_ = VK_NULL_HANDLE;
    VkPhysicalDevice physicalDevice_ = VK_NULL_HANDLE;
    VkDevice device_ = VK_NULL_HANDLE;
    VkQueue queue_ = VK_NULL_HANDLE;
    uint32_t queueFamily_ = 0;
    VkCommandPool commandPool_ = VK_NULL_HANDLE;
    VkFence fence_ = VK_NULL_HANDLE;
    double submitTimeoutSeconds_ = 60.0;
    bool isolatePasses_ = false;
    std::optional<Presentation> presentation_;
    bool presents_ = false;
    DeviceInfo info_;
    VkPhysicalDeviceProperties properties_{};
    VkPhysicalDeviceMemoryProperties memoryProperties_{};
    VkDeviceSize maxMemoryAllocationSize_ = 0;
    bool validation_ = false;
    bool debugUtils_ = false;
    std::atomic<uint32_t> validationMessages_{0};
    mutable std::mutex messagesMutex_;
    std::vector<std::string> firstMessages_;
    PFN_vkSetDebugUtilsObjectNameEXT setObjectName_ = nullptr;
    PFN_vkCmdBeginDebugUtilsLabelEXT cmdBeginLabel_ = nullptr;
    PFN_vkCmdEndDebugUtilsLabelEXT cmdEndLabel_ = nullptr;
    PFN_vkCmdPushDescriptorSetKHR cmdPushDescriptorSet_ = nullptr;
    VkPhysicalDeviceFeatures enabledFeatures_{};
    FaultHooks faultHooks_;
};

} // namespace penumbra::gpu
