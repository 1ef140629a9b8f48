#include "penumbra/gpu/Context.h"

#include "penumbra/core/Error.h"
#include "penumbra/gpu/Check.h"
#include "SanitizerSupport.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <cstring>

namespace penumbra::gpu {
namespace {

constexpr const char* kValidationLayer = "VK_LAYER_KHRONOS_validation";
constexpr size_t kKeptMessages = 16;

std::string lower(std::string s)
{
    std::transform(s.begin(), s.end(), s.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return s;
}

const char* typeName(VkPhysicalDeviceType type)
{
    switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return "discrete";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return "integrated";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return "virtual";
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return "cpu";
    default: return "other";
    }
}

// Preference when the user names nothing: a real GPU before a software rasterizer.
int typeRank(VkPhysicalDeviceType type)
{
    switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return 4;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return 3;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return 1;
    default: return 0;
    }
}

std::string versionString(uint32_t v)
{
    return fmt::format("{}.{}.{}", VK_API_VERSION_MAJOR(v), VK_API_VERSION_MINOR(v),
                       VK_API_VERSION_PATCH(v));
}

bool hasLayer(const char* name)
{
    uint32_t count = 0;
    vkEnumerateInstanceLayerProperties(&count, nullptr);
    std::vector<VkLayerProperties> layers(count);
    vkEnumerateInstanceLayerProperties(&count, layers.data());
    return std::any_of(layers.begin(), layers.end(),
                       [&](const VkLayerProperties& l) { return std::strcmp(l.layerName, name) == 0; });
}

bool hasInstanceExtension(const char* name)
{
    uint32_t count = 0;
    vkEnumerateInstanceExtensionProperties(nullptr, &count, nullptr);
    std::vector<VkExtensionProperties> exts(count);
    vkEnumerateInstanceExtensionProperties(nullptr, &count, exts.data());
    return std::any_of(exts.begin(), exts.end(), [&](const VkExtensionProperties& e) {
        return std::strcmp(e.extensionName, name) == 0;
    });
}

bool hasDeviceExtension(VkPhysicalDevice device, const char* name)
{
    uint32_t count = 0;
    vkEnumerateDeviceExtensionProperties(device, nullptr, &count, nullptr);
    std::vector<VkExtensionProperties> exts(count);
    vkEnumerateDeviceExtensionProperties(device, nullptr, &count, exts.data());
    return std::any_of(exts.begin(), exts.end(), [&](const VkExtensionProperties& e) {
        return std::strcmp(e.extensionName, name) == 0;
    });
}

std::vector<VkPhysicalDevice> enumerateDevices(VkInstance instance)
{
    uint32_t count = 0;
    check(vkEnumeratePhysicalDevices(instance, &count, nullptr), "vkEnumeratePhysicalDevices");
    std::vector<VkPhysicalDevice> devices(count);
    check(vkEnumeratePhysicalDevices(instance, &count, devices.data()), "vkEnumeratePhysicalDevices");
    return devices;
}

DeviceInfo describe(VkPhysicalDevice device)
{
    VkPhysicalDeviceDriverProperties driver{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES};
    VkPhysicalDeviceProperties2 props{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2, &driver};
    vkGetPhysicalDeviceProperties2(device, &props);
    DeviceInfo info;
    info.name = props.properties.deviceName;
    info.type = typeName(props.properties.deviceType);
    info.apiVersion = props.properties.apiVersion;
    info.driverInfo = fmt::format("{} {}", driver.driverName, driver.driverInfo);
    return info;
}

// What the engine needs from a device; empty when it has all of it.
std::string missingRequirements(VkPhysicalDevice device)
{
    VkPhysicalDeviceProperties props{};
    vkGetPhysicalDeviceProperties(device, &props);
    if (props.apiVersion < VK_API_VERSION_1_3) {
        return fmt::format("Vulkan {} < 1.3", versionString(props.apiVersion));
    }
    VkPhysicalDeviceVulkan13Features f13{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES};
    VkPhysicalDeviceFeatures2 f{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, &f13};
    vkGetPhysicalDeviceFeatures2(device, &f);
    std::vector<std::string> missing;
    if (!f13.dynamicRendering) missing.emplace_back("dynamicRendering");
    if (!f13.synchronization2) missing.emplace_back("synchronization2");
    if (!f13.maintenance4) missing.emplace_back("maintenance4");
    if (!f.features.depthBiasClamp) missing.emplace_back("depthBiasClamp");
    if (!hasDeviceExtension(device, VK_KHR_PUSH_DESCRIPTOR_EXTENSION_NAME))
        missing.emplace_back(VK_KHR_PUSH_DESCRIPTOR_EXTENSION_NAME);
    return fmt::format("{}", fmt::join(missing, ", "));
}

} // namespace

bool validationByDefault()
{
#ifdef NDEBUG
    return false;
#else
    return true;
#endif
}

ContextOptions contextOptionsFromEnvironment(ContextOptions base)
{
    if (const char* env = std::getenv("PENUMBRA_DEVICE"); env && *env &&
        base.device.nameContains.empty() && base.device.type.empty()) {
        std::string value = env;
        if (value.rfind("type:", 0) == 0) {
            base.device.type = value.substr(5);
        } else {
            base.device.nameContains = value;
        }
    }
    if (const char* env = std::getenv("PENUMBRA_VALIDATION"); env && *env) {
        base.validation = std::string(env) != "0";
    }
    if (const char* env = std::getenv("PENUMBRA_ISOLATE_PASSES"); env && *env) {
        base.isolatePasses = std::string(env) != "0";
    }
    if (const char* env = std::getenv("PENUMBRA_GPU_TIMEOUT_S"); env && *env) {
        char* end = nullptr;
        const double seconds = std::strtod(env, &end);
        if (end == env || *end != '\0' || !(seconds > 0.0 && seconds <= 1e6)) {
            throw ConfigError(fmt::format("PENUMBRA_GPU_TIMEOUT_S: must be a number of seconds in (0, 1e6], got \"{}\"",
                                          env));
        }
        base.submitTimeoutSeconds = seconds;
    }
    return base;
}

Context::Context(const ContextOptions& options)
    : submitTimeoutSeconds_(options.submitTimeoutSeconds), isolatePasses_(options.isolatePasses),
      presentation_(options.presentation)
{
    try {
        createInstance(options.validation, presentation_ ? presentation_->instanceExtensions : std::vector<std::string>{});
        selectPhysicalDevice(options.device);
        createDevice();
    } catch (...) {
        destroy();
        throw;
    }
}

Context::~Context() { destroy(); }

void Context::destroy()
{
    if (device_) {
        vkDeviceWaitIdle(device_);
        if (fence_) vkDestroyFence(device_, fence_, nullptr);
        if (commandPool_) vkDestroyCommandPool(device_, commandPool_, nullptr);
        vkDestroyDevice(device_, nullptr);
        device_ = VK_NULL_HANDLE;
    }
    if (messenger_) {
        auto destroyMessenger = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
            vkGetInstanceProcAddr(instance_, "vkDestroyDebugUtilsMessengerEXT"));
        destroyMessenger(instance_, messenger_, nullptr);
        messenger_ = VK_NULL_HANDLE;
    }
    if (instance_) {
        vkDestroyInstance(instance_, nullptr);
        instance_ = VK_NULL_HANDLE;
    }
}

void Context::createInstance(bool validation, const std::vector<std::string>& extraExtensions)
{
    uint32_t loaderVersion = 0;
    if (vkEnumerateInstanceVersion(&loaderVersion) != VK_SUCCESS || loaderVersion < VK_API_VERSION_1_3) {
        throw GpuError(fmt::format("the Vulkan loader supports {} but Penumbra needs 1.3 "
                                   "(install libvulkan1 from Debian 12 or newer)",
                                   versionString(loaderVersion)));
    }
    if (validation && !hasLayer(kValidationLayer)) {
        throw GpuError(fmt::format("validation requested but {} is not installed "
                                   "(apt-get install vulkan-validationlayers)", kValidationLayer));
    }
    validation_ = validation;
    debugUtils_ = validation;

    VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
    app.pApplicationName = "penumbra";
    app.pEngineName = "penumbra";
    app.apiVersion = VK_API_VERSION_1_3;

    std::vector<const char*> layers;
    std::vector<const char*> extensions;
    if (validation) {
        layers.push_back(kValidationLayer);
        extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
    }
    for (const std::string& extension : extraExtensions) {
        if (!hasInstanceExtension(extension.c_str())) {
            throw GpuError(fmt::format("the Vulkan loader has no instance extension {}, which the window system needs "
                                       "(install the Vulkan driver's window-system support, e.g. mesa-vulkan-drivers)",
                                       extension));
        }
        extensions.push_back(extension.c_str());
    }

    // Synchronization validation catches missing barriers: the graph of a later issue
    // derives them, and tests must prove it derives them right.
    VkValidationFeatureEnableEXT enables[] = {VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT};
    VkValidationFeaturesEXT features{VK_STRUCTURE_TYPE_VALIDATION_FEATURES_EXT};
    features.enabledValidationFeatureCount = 1;
    features.pEnabledValidationFeatures = enables;

    VkDebugUtilsMessengerCreateInfoEXT messengerInfo{VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT};
    messengerInfo.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT |
                                    VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
    messengerInfo.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT |
                                VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                                VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
    messengerInfo.pfnUserCallback = &Context::onDebugMessage;
    messengerInfo.pUserData = this;
    messengerInfo.pNext = &features;

    VkInstanceCreateInfo info{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
    info.pApplicationInfo = &app;
    info.enabledLayerCount = static_cast<uint32_t>(layers.size());
    info.ppEnabledLayerNames = layers.data();
    info.enabledExtensionCount = static_cast<uint32_t>(extensions.size());
    info.ppEnabledExtensionNames = extensions.data();
    if (validation) {
        info.pNext = &messengerInfo;
    }
    check(vkCreateInstance(&info, nullptr, &instance_), "vkCreateInstance");
    pinLoadedLibrariesForLeakReports();

    if (validation) {
        messengerInfo.pNext = nullptr;
        auto createMessenger = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
            vkGetInstanceProcAddr(instance_, "vkCreateDebugUtilsMessengerEXT"));
        check(createMessenger(instance_, &messengerInfo, nullptr, &messenger_),
              "vkCreateDebugUtilsMessengerEXT");
        setObjectName_ = reinterpret_cast<PFN_vkSetDebugUtilsObjectNameEXT>(
            vkGetInstanceProcAddr(instance_, "vkSetDebugUtilsObjectNameEXT"));
        cmdBeginLabel_ = reinterpret_cast<PFN_vkCmdBeginDebugUtilsLabelEXT>(
            vkGetInstanceProcAddr(instance_, "vkCmdBeginDebugUtilsLabelEXT"));
        cmdEndLabel_ = reinterpret_cast<PFN_vkCmdEndDebugUtilsLabelEXT>(
            vkGetInstanceProcAddr(instance_, "vkCmdEndDebugUtilsLabelEXT"));
    }
}

void Context::selectPhysicalDevice(const DeviceRequest& request)
{
    const std::vector<VkPhysicalDevice> devices = enumerateDevices(instance_);
    if (devices.empty()) {
        throw GpuError("no Vulkan device found: the loader reports no physical device "
                       "(install mesa-vulkan-drivers for lavapipe, or a GPU driver; "
                       "check VK_DRIVER_FILES / VK_ICD_FILENAMES)");
    }
    static const char* kTypes[] = {"discrete", "integrated", "virtual", "cpu"};
    if (!request.type.empty() &&
        std::none_of(std::begin(kTypes), std::end(kTypes), [&](const char* t) { return request.type == t; })) {
        throw GpuError(fmt::format("unknown device type '{}': expected discrete, integrated, virtual or cpu",
                                   request.type));
    }

    std::vector<std::string> available;
    std::vector<std::string> rejected;
    VkPhysicalDevice best = VK_NULL_HANDLE;
    int bestRank = -1;
    for (VkPhysicalDevice device : devices) {
        VkPhysicalDeviceProperties props{};
        vkGetPhysicalDeviceProperties(device, &props);
        const std::string name = props.deviceName;
        const std::string type = typeName(props.deviceType);
        available.push_back(fmt::format("'{}' ({})", name, type));
        if (!request.nameContains.empty() &&
            lower(name).find(lower(request.nameContains)) == std::string::npos) {
            continue;
        }
        if (!request.type.empty() && request.type != type) {
            continue;
        }
        if (std::string missing = missingRequirements(device); !missing.empty()) {
            rejected.push_back(fmt::format("'{}' lacks {}", name, missing));
            continue;
        }
        if (presentation_ && !hasDeviceExtension(device, VK_KHR_SWAPCHAIN_EXTENSION_NAME)) {
            rejected.push_back(fmt::format("'{}' lacks {} (a window needs it)", name, VK_KHR_SWAPCHAIN_EXTENSION_NAME));
            continue;
        }
        if (!queueFamilyOf(device)) {
            rejected.push_back(fmt::format("'{}' has no queue family with graphics, compute and timestamps{}", name,
                                           presentation_ ? " that can present to the window" : ""));
            continue;
        }
        if (typeRank(props.deviceType) > bestRank) {
            best = device;
            bestRank = typeRank(props.deviceType);
        }
    }
    if (!best) {
        std::string wanted = request.nameContains.empty() && request.type.empty()
                                 ? std::string("a Vulkan 1.3 device")
                                 : fmt::format("a device{}{}",
                                               request.nameContains.empty() ? "" : " named like '" + request.nameContains + "'",
                                               request.type.empty() ? "" : " of type '" + request.type + "'");
        throw GpuError(fmt::format("no suitable device: wanted {}; available: {}{}", wanted,
                                   fmt::join(available, ", "),
                                   rejected.empty() ? "" : fmt::format("; rejected: {}", fmt::join(rejected, "; "))));
    }
    physicalDevice_ = best;
    info_ = describe(best);
    vkGetPhysicalDeviceProperties(best, &properties_);
    vkGetPhysicalDeviceMemoryProperties(best, &memoryProperties_);
    VkPhysicalDeviceMaintenance3Properties maintenance3{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MAINTENANCE_3_PROPERTIES};
    VkPhysicalDeviceProperties2 properties2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
    properties2.pNext = &maintenance3;
    vkGetPhysicalDeviceProperties2(best, &properties2);
    maxMemoryAllocationSize_ = maintenance3.maxMemoryAllocationSize;
}

std::optional<uint32_t> Context::queueFamilyOf(VkPhysicalDevice device) const
{
    uint32_t familyCount = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(device, &familyCount, nullptr);
    std::vector<VkQueueFamilyProperties> families(familyCount);
    vkGetPhysicalDeviceQueueFamilyProperties(device, &familyCount, families.data());
    for (uint32_t i = 0; i < familyCount; ++i) {
        const VkQueueFlags need = VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT;
        if ((families[i].queueFlags & need) != need || families[i].timestampValidBits == 0) continue;
        // One queue does everything: the frame, its timings and the window's present.
        if (presentation_ && !(presentation_->canPresent && presentation_->canPresent(instance_, device, i))) continue;
        return i;
    }
    return std::nullopt;
}

void Context::createDevice()
{
    queueFamily_ = *queueFamilyOf(physicalDevice_);  // selectPhysicalDevice took only a device that has one

    VkPhysicalDeviceVulkan13Features have13{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES};
    VkPhysicalDeviceVulkan12Features have12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES, &have13};
    VkPhysicalDeviceFeatures2 have{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, &have12};
    vkGetPhysicalDeviceFeatures2(physicalDevice_, &have);

    VkPhysicalDeviceVulkan13Features f13{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES};
    f13.dynamicRendering = VK_TRUE;
    f13.synchronization2 = VK_TRUE;
    f13.maintenance4 = VK_TRUE;
    VkPhysicalDeviceVulkan12Features f12{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES, &f13};
    f12.hostQueryReset = have12.hostQueryReset;
    f12.scalarBlockLayout = have12.scalarBlockLayout;
    f12.bufferDeviceAddress = have12.bufferDeviceAddress;
    VkPhysicalDeviceFeatures2 features{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2, &f12};
    features.features.depthBiasClamp = VK_TRUE;
    // Optional features later techniques use where the device has them.
    features.features.depthClamp = have.features.depthClamp;
    features.features.shaderInt64 = have.features.shaderInt64;
    features.features.shaderFloat64 = have.features.shaderFloat64;
    features.features.geometryShader = have.features.geometryShader;
    // Batched scene draws (render::SceneGpu): one indirect call per texture, each command
    // with its own first instance.
    features.features.multiDrawIndirect = have.features.multiDrawIndirect;
    features.features.drawIndirectFirstInstance = have.features.drawIndirectFirstInstance;
    features.features.occlusionQueryPrecise = have.features.occlusionQueryPrecise;
    features.features.pipelineStatisticsQuery = have.features.pipelineStatisticsQuery;
    features.features.fragmentStoresAndAtomics = have.features.fragmentStoresAndAtomics;
    features.features.shaderStorageImageExtendedFormats = have.features.shaderStorageImageExtendedFormats;

    const float priority = 1.0f;
    VkDeviceQueueCreateInfo queueInfo{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
    queueInfo.queueFamilyIndex = queueFamily_;
    queueInfo.queueCount = 1;
    queueInfo.pQueuePriorities = &priority;

    std::vector<const char*> extensions = {VK_KHR_PUSH_DESCRIPTOR_EXTENSION_NAME};
    if (presentation_) extensions.push_back(VK_KHR_SWAPCHAIN_EXTENSION_NAME);
    VkDeviceCreateInfo info{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO, &features};
    info.queueCreateInfoCount = 1;
    info.pQueueCreateInfos = &queueInfo;
    info.enabledExtensionCount = uint32_t(extensions.size());
    info.ppEnabledExtensionNames = extensions.data();
    check(vkCreateDevice(physicalDevice_, &info, nullptr, &device_), "vkCreateDevice");
    enabledFeatures_ = features.features;
    presents_ = presentation_.has_value();
    pinLoadedLibrariesForLeakReports();
    vkGetDeviceQueue(device_, queueFamily_, 0, &queue_);
    cmdPushDescriptorSet_ = reinterpret_cast<PFN_vkCmdPushDescriptorSetKHR>(
        vkGetDeviceProcAddr(device_, "vkCmdPushDescriptorSetKHR"));

    VkCommandPoolCreateInfo poolInfo{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
    poolInfo.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
    poolInfo.queueFamilyIndex = queueFamily_;
    check(vkCreateCommandPool(device_, &poolInfo, nullptr, &commandPool_), "vkCreateCommandPool");
    VkFenceCreateInfo fenceInfo{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    check(vkCreateFence(device_, &fenceInfo, nullptr, &fence_), "vkCreateFence");
    spdlog::debug("device: {} ({}), Vulkan {}, {}", info_.name, info_.type, versionString(info_.apiVersion),
                  info_.driverInfo);
}

std::vector<DeviceInfo> Context::listDevices()
{
    VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
    app.apiVersion = VK_API_VERSION_1_3;
    VkInstanceCreateInfo info{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
    info.pApplicationInfo = &app;
    VkInstance instance = VK_NULL_HANDLE;
    check(vkCreateInstance(&info, nullptr, &instance), "vkCreateInstance");
    pinLoadedLibrariesForLeakReports();
    std::vector<DeviceInfo> out;
    try {
        for (VkPhysicalDevice device : enumerateDevices(instance)) {
            out.push_back(describe(device));
        }
    } catch (...) {
        vkDestroyInstance(instance, nullptr);
        throw;
    }
    vkDestroyInstance(instance, nullptr);
    return out;
}

std::vector<std::string> Context::validationMessages() const
{
    std::lock_guard lock(messagesMutex_);
    return firstMessages_;
}

uint32_t Context::findMemoryType(uint32_t typeBits, VkMemoryPropertyFlags required,
                                 VkMemoryPropertyFlags preferred) const
{
    std::optional<uint32_t> fallback;
    for (uint32_t i = 0; i < memoryProperties_.memoryTypeCount; ++i) {
        const VkMemoryPropertyFlags flags = memoryProperties_.memoryTypes[i].propertyFlags;
        if (!(typeBits & (1u << i)) || (flags & required) != required) {
            continue;
        }
        if ((flags & preferred) == preferred) {
            return i;
        }
        if (!fallback) {
            fallback = i;
        }
    }
    if (!fallback) {
        throw GpuError(fmt::format("device '{}' has no memory type with flags {:#x} among bits {:#x}",
                                   info_.name, required, typeBits));
    }
    return *fallback;
}

VkDeviceMemory Context::allocateMemory(const VkMemoryAllocateInfo& info, std::string_view what, std::string_view lower)
{
    VkResult result = faultHooks_.allocate ? faultHooks_.allocate(info.allocationSize, what) : VK_SUCCESS;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    if (result == VK_SUCCESS) result = vkAllocateMemory(device_, &info, nullptr, &memory);
    if (result == VK_ERROR_OUT_OF_DEVICE_MEMORY || result == VK_ERROR_OUT_OF_HOST_MEMORY) {
        const uint32_t heap = info.memoryTypeIndex < memoryProperties_.memoryTypeCount
                                  ? memoryProperties_.memoryTypes[info.memoryTypeIndex].heapIndex
                                  : 0;
        constexpr double kMiB = 1024.0 * 1024.0;
        throw VulkanError(fmt::format("out of {} memory: {} needs {:.1f} MiB ({} bytes) of heap {} ({:.0f} MiB on '{}'); "
                                      "{} ({})",
                                      result == VK_ERROR_OUT_OF_DEVICE_MEMORY ? "device" : "host", what,
                                      double(info.allocationSize) / kMiB, uint64_t(info.allocationSize), heap,
                                      double(memoryProperties_.memoryHeaps[heap].size) / kMiB, info_.name, lower,
                                      resultName(result)),
                          result);
    }
    check(result, fmt::format("vkAllocateMemory for {}", what));
    return memory;
}

void Context::submitAndWait(const std::function<void(VkCommandBuffer)>& record)
{
    VkCommandBufferAllocateInfo alloc{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
    alloc.commandPool = commandPool_;
    alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    alloc.commandBufferCount = 1;
    VkCommandBuffer cmd = VK_NULL_HANDLE;
    check(vkAllocateCommandBuffers(device_, &alloc, &cmd), "vkAllocateCommandBuffers");
    struct Free {
        VkDevice d;
        VkCommandPool p;
        VkCommandBuffer c;
        ~Free() { vkFreeCommandBuffers(d, p, 1, &c); }
    } freeLater{device_, commandPool_, cmd};

    VkCommandBufferBeginInfo begin{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    check(vkBeginCommandBuffer(cmd, &begin), "vkBeginCommandBuffer");
    record(cmd);
    check(vkEndCommandBuffer(cmd), "vkEndCommandBuffer");

    submitAndWait(cmd);
}

void Context::submitAndWait(VkCommandBuffer cmd)
{
    VkCommandBufferSubmitInfo cmdInfo{VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO};
    cmdInfo.commandBuffer = cmd;
    VkSubmitInfo2 submit{VK_STRUCTURE_TYPE_SUBMIT_INFO_2};
    submit.commandBufferInfoCount = 1;
    submit.pCommandBufferInfos = &cmdInfo;
    const VkResult injected = faultHooks_.submit ? faultHooks_.submit() : VK_SUCCESS;
    check(injected == VK_SUCCESS ? vkQueueSubmit2(queue_, 1, &submit, fence_) : injected, "vkQueueSubmit2");
    // A finite wait: a hung submission becomes an error, never a hang
    // (ContextOptions::submitTimeoutSeconds).
    const double seconds = std::clamp(submitTimeoutSeconds_, 1e-3, 1e6);
    const auto timeoutNs = uint64_t(seconds * 1e9);
    const VkResult waited = vkWaitForFences(device_, 1, &fence_, VK_TRUE, timeoutNs);
    if (waited == VK_TIMEOUT) {
        throw GpuError(fmt::format("GPU submission did not finish within {} s (device hang? PENUMBRA_GPU_TIMEOUT_S "
                                   "raises the limit)",
                                   seconds));
    }
    check(waited, "vkWaitForFences");
    check(vkResetFences(device_, 1, &fence_), "vkResetFences");
}

void Context::pushDescriptorSet(VkCommandBuffer cmd, VkPipelineBindPoint bindPoint, VkPipelineLayout layout,
                                const std::vector<VkWriteDescriptorSet>& writes) const
{
    cmdPushDescriptorSet_(cmd, bindPoint, layout, 0, static_cast<uint32_t>(writes.size()), writes.data());
}

void Context::setName(VkObjectType type, uint64_t handle, const std::string& name) const
{
    if (!setObjectName_) {
        return;
    }
    VkDebugUtilsObjectNameInfoEXT info{VK_STRUCTURE_TYPE_DEBUG_UTILS_OBJECT_NAME_INFO_EXT};
    info.objectType = type;
    info.objectHandle = handle;
    info.pObjectName = name.c_str();
    setObjectName_(device_, &info);
}

void Context::beginLabel(VkCommandBuffer cmd, const std::string& name) const
{
    if (!cmdBeginLabel_) {
        return;
    }
    VkDebugUtilsLabelEXT label{VK_STRUCTURE_TYPE_DEBUG_UTILS_LABEL_EXT};
    label.pLabelName = name.c_str();
    cmdBeginLabel_(cmd, &label);
}

void Context::endLabel(VkCommandBuffer cmd) const
{
    if (cmdEndLabel_) {
        cmdEndLabel_(cmd);
    }
}

namespace {
std::atomic<uint64_t> gValidationMessagesInProcess{0};
}

uint64_t validationMessagesInProcess() { return gValidationMessagesInProcess.load(); }

VKAPI_ATTR VkBool32 VKAPI_CALL Context::onDebugMessage(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                                       VkDebugUtilsMessageTypeFlagsEXT,
                                                       const VkDebugUtilsMessengerCallbackDataEXT* data,
                                                       void* self)
{
    auto* context = static_cast<Context*>(self);
    const char* text = data && data->pMessage ? data->pMessage : "(no message)";
    context->validationMessages_.fetch_add(1);
    gValidationMessagesInProcess.fetch_add(1);
    {
        std::lock_guard lock(context->messagesMutex_);
        if (context->firstMessages_.size() < kKeptMessages) {
            context->firstMessages_.emplace_back(text);
        }
    }
    if (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT) {
        spdlog::error("vulkan validation: {}", text);
    } else {
        spdlog::warn("vulkan validation: {}", text);
    }
    return VK_FALSE;
}

} // namespace penumbra::gpu
