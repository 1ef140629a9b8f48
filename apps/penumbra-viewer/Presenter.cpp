#include "Presenter.h"

#include "PanelLayer.h"

#include "penumbra/gpu/Barrier.h"
#include "penumbra/gpu/Check.h"

#define GLFW_INCLUDE_NONE
#define GLFW_INCLUDE_VULKAN
#include <GLFW/glfw3.h>
#include <fmt/format.h>
#include <imgui.h>
#include <backends/imgui_impl_vulkan.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <optional>

namespace penumbra::viewer {
namespace {

// A swapchain image's layout change (they are not gpu::Images).
void barrier(VkCommandBuffer cmd, VkImage image, VkImageLayout from, VkImageLayout to, VkPipelineStageFlags2 srcStage,
             VkAccessFlags2 srcAccess, VkPipelineStageFlags2 dstStage, VkAccessFlags2 dstAccess)
{
    VkImageMemoryBarrier2 b{VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2};
    b.srcStageMask = srcStage;
    b.srcAccessMask = srcAccess;
    b.dstStageMask = dstStage;
    b.dstAccessMask = dstAccess;
    b.oldLayout = from;
    b.newLayout = to;
    b.srcQueueFamilyIndex = b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    b.image = image;
    b.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    VkDependencyInfo dep{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
    dep.imageMemoryBarrierCount = 1;
    dep.pImageMemoryBarriers = &b;
    vkCmdPipelineBarrier2(cmd, &dep);
}

void checkImGuiResult(VkResult result) { gpu::check(result, "Dear ImGui's Vulkan backend"); }

} // namespace

// The window's pixels outside every view, as up to four bands around the views' bounding
// box (views are side by side, so that box is what they cover).
std::vector<VkRect2D> Presenter::uncoveredRects(const std::vector<ViewBlit>& views) const
{
    int32_t x0 = int32_t(extent_.width), y0 = int32_t(extent_.height), x1 = 0, y1 = 0;
    for (const ViewBlit& v : views) {
        if (!v.image || v.target.extent.width == 0 || v.target.extent.height == 0) continue;
        x0 = std::min(x0, std::max(v.target.offset.x, 0));
        y0 = std::min(y0, std::max(v.target.offset.y, 0));
        x1 = std::max(x1, std::min(v.target.offset.x + int32_t(v.target.extent.width), int32_t(extent_.width)));
        y1 = std::max(y1, std::min(v.target.offset.y + int32_t(v.target.extent.height), int32_t(extent_.height)));
    }
    if (x1 <= x0 || y1 <= y0) return {{{0, 0}, extent_}};
    std::vector<VkRect2D> out;
    const int32_t w = int32_t(extent_.width), h = int32_t(extent_.height);
    auto add = [&](int32_t ax, int32_t ay, int32_t bx, int32_t by) {
        if (bx > ax && by > ay) out.push_back({{ax, ay}, {uint32_t(bx - ax), uint32_t(by - ay)}});
    };
    add(0, 0, w, y0);    // above
    add(0, y1, w, h);    // below
    add(0, y0, x0, y1);  // left
    add(x1, y0, w, y1);  // right
    return out;
}


void UploadedImage::set(uint32_t width, uint32_t height, const std::vector<uint8_t>& rgba)
{
    const VkDeviceSize bytes = VkDeviceSize(width) * height * 4;
    if (rgba.size() != bytes) throw Error(fmt::format("{}: {} bytes for {} x {} RGBA8", name_, rgba.size(), width, height));
    const bool fresh = empty() || image_.desc().width != width || image_.desc().height != height;
    if (fresh) {
        gpu::ImageDesc desc;
        desc.width = width;
        desc.height = height;
        desc.format = VK_FORMAT_R8G8B8A8_UNORM;
        desc.usage = VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
        desc.name = name_;
        image_ = gpu::Image(context_, desc);
    }
    if (staging_.size() < bytes) {
        staging_ = gpu::Buffer(context_, bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, true, std::string(name_) + " (upload)");
    }
    std::memcpy(staging_.mapped(), rgba.data(), bytes);
    context_.submitAndWait([&](VkCommandBuffer cmd) {
        const gpu::ImageAccess shown{kLayout, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_READ_BIT};
        const gpu::ImageAccess copy{VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_PIPELINE_STAGE_2_COPY_BIT,
                                    VK_ACCESS_2_TRANSFER_WRITE_BIT};
        gpu::transition(cmd, image_, fresh ? gpu::access::kUndefined : shown, copy);
        VkBufferImageCopy region{};
        region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        region.imageExtent = {width, height, 1};
        vkCmdCopyBufferToImage(cmd, staging_.handle(), image_.handle(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
        gpu::transition(cmd, image_, copy, shown);
    });
}

Presenter::Presenter(gpu::Context& context, GLFWwindow* window, bool vsync)
    : context_(context), window_(window), vsync_(vsync)
{
    try {
        gpu::check(glfwCreateWindowSurface(context_.instance(), window_, nullptr, &surface_), "glfwCreateWindowSurface");
        VkBool32 supported = VK_FALSE;
        gpu::check(vkGetPhysicalDeviceSurfaceSupportKHR(context_.physicalDevice(), context_.queueFamily(), surface_, &supported),
                   "vkGetPhysicalDeviceSurfaceSupportKHR");
        if (!supported) {
            throw GpuError(fmt::format("device '{}' cannot present to this window's surface", context_.deviceInfo().name));
        }
        VkCommandPoolCreateInfo poolInfo{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
        poolInfo.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
        poolInfo.queueFamilyIndex = context_.queueFamily();
        gpu::check(vkCreateCommandPool(context_.device(), &poolInfo, nullptr, &pool_), "vkCreateCommandPool");
        VkCommandBufferAllocateInfo alloc{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
        alloc.commandPool = pool_;
        alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
        alloc.commandBufferCount = 1;
        gpu::check(vkAllocateCommandBuffers(context_.device(), &alloc, &cmd_), "vkAllocateCommandBuffers");
        VkSemaphoreCreateInfo semaphoreInfo{VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO};
        gpu::check(vkCreateSemaphore(context_.device(), &semaphoreInfo, nullptr, &acquired_), "vkCreateSemaphore");
        VkFenceCreateInfo fenceInfo{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
        fenceInfo.flags = VK_FENCE_CREATE_SIGNALED_BIT;
        gpu::check(vkCreateFence(context_.device(), &fenceInfo, nullptr, &done_), "vkCreateFence");
        createSwapchain();
        initImGui();
    } catch (...) {
        release();
        throw;
    }
}

Presenter::~Presenter() { release(); }

void Presenter::release()
{
    VkDevice device = context_.device();
    if (device) vkDeviceWaitIdle(device);
    if (imguiReady_) {
        ImGui_ImplVulkan_Shutdown();
        imguiReady_ = false;
    }
    destroySwapchain();
    timer_.reset();
    if (renderPass_) vkDestroyRenderPass(device, renderPass_, nullptr);
    if (imguiPool_) vkDestroyDescriptorPool(device, imguiPool_, nullptr);
    if (done_) vkDestroyFence(device, done_, nullptr);
    if (acquired_) vkDestroySemaphore(device, acquired_, nullptr);
    if (pool_) vkDestroyCommandPool(device, pool_, nullptr);
    if (surface_) vkDestroySurfaceKHR(context_.instance(), surface_, nullptr);
    renderPass_ = VK_NULL_HANDLE;
    imguiPool_ = VK_NULL_HANDLE;
    done_ = VK_NULL_HANDLE;
    acquired_ = VK_NULL_HANDLE;
    pool_ = VK_NULL_HANDLE;
    surface_ = VK_NULL_HANDLE;
}

void Presenter::createSwapchain()
{
    VkPhysicalDevice gpu = context_.physicalDevice();
    VkSurfaceCapabilitiesKHR caps{};
    gpu::check(vkGetPhysicalDeviceSurfaceCapabilitiesKHR(gpu, surface_, &caps), "vkGetPhysicalDeviceSurfaceCapabilitiesKHR");
    int width = 0, height = 0;
    glfwGetFramebufferSize(window_, &width, &height);
    extent_ = caps.currentExtent.width != UINT32_MAX
                  ? caps.currentExtent
                  : VkExtent2D{std::clamp(uint32_t(std::max(width, 0)), caps.minImageExtent.width, caps.maxImageExtent.width),
                               std::clamp(uint32_t(std::max(height, 0)), caps.minImageExtent.height, caps.maxImageExtent.height)};
    if (extent_.width == 0 || extent_.height == 0) return;  // minimised: no swapchain until it has a size

    uint32_t count = 0;
    vkGetPhysicalDeviceSurfaceFormatsKHR(gpu, surface_, &count, nullptr);
    std::vector<VkSurfaceFormatKHR> formats(count);
    vkGetPhysicalDeviceSurfaceFormatsKHR(gpu, surface_, &count, formats.data());
    if (formats.empty()) throw GpuError("the window's surface offers no image format");
    // UNORM: the frame's colour image holds sRGB-encoded bytes already (shading.comp), and
    // ImGui's colours are sRGB values; both are copied, not encoded again.
    VkSurfaceFormatKHR chosen = formats.front();
    for (const VkSurfaceFormatKHR& f : formats) {
        if ((f.format == VK_FORMAT_B8G8R8A8_UNORM || f.format == VK_FORMAT_R8G8B8A8_UNORM) &&
            f.colorSpace == VK_COLOR_SPACE_SRGB_NONLINEAR_KHR) {
            chosen = f;
            break;
        }
    }
    const bool formatChanged = format_ != chosen.format;
    format_ = chosen.format;

    vkGetPhysicalDeviceSurfacePresentModesKHR(gpu, surface_, &count, nullptr);
    std::vector<VkPresentModeKHR> modes(count);
    vkGetPhysicalDeviceSurfacePresentModesKHR(gpu, surface_, &count, modes.data());
    auto has = [&](VkPresentModeKHR m) { return std::find(modes.begin(), modes.end(), m) != modes.end(); };
    presentMode_ = VK_PRESENT_MODE_FIFO_KHR;  // always there: vsync
    if (!vsync_) {
        if (has(VK_PRESENT_MODE_MAILBOX_KHR)) presentMode_ = VK_PRESENT_MODE_MAILBOX_KHR;
        else if (has(VK_PRESENT_MODE_IMMEDIATE_KHR)) presentMode_ = VK_PRESENT_MODE_IMMEDIATE_KHR;
    }

    canReadBack_ = (caps.supportedUsageFlags & VK_IMAGE_USAGE_TRANSFER_SRC_BIT) != 0;
    if (!(caps.supportedUsageFlags & VK_IMAGE_USAGE_TRANSFER_DST_BIT)) {
        throw GpuError("the window's swapchain images cannot be copied to (no TRANSFER_DST usage)");
    }
    VkSwapchainCreateInfoKHR info{VK_STRUCTURE_TYPE_SWAPCHAIN_CREATE_INFO_KHR};
    info.surface = surface_;
    info.minImageCount = std::max(caps.minImageCount + 1, 2u);
    if (caps.maxImageCount) info.minImageCount = std::min(info.minImageCount, caps.maxImageCount);
    info.imageFormat = chosen.format;
    info.imageColorSpace = chosen.colorSpace;
    info.imageExtent = extent_;
    info.imageArrayLayers = 1;
    info.imageUsage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT |
                      (canReadBack_ ? VK_IMAGE_USAGE_TRANSFER_SRC_BIT : 0);
    info.imageSharingMode = VK_SHARING_MODE_EXCLUSIVE;
    info.preTransform = caps.currentTransform;
    info.compositeAlpha = (caps.supportedCompositeAlpha & VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR)
                              ? VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR
                              : VkCompositeAlphaFlagBitsKHR(caps.supportedCompositeAlpha & -caps.supportedCompositeAlpha);
    info.presentMode = presentMode_;
    info.clipped = VK_TRUE;
    gpu::check(vkCreateSwapchainKHR(context_.device(), &info, nullptr, &swapchain_), "vkCreateSwapchainKHR");

    vkGetSwapchainImagesKHR(context_.device(), swapchain_, &count, nullptr);
    images_.resize(count);
    vkGetSwapchainImagesKHR(context_.device(), swapchain_, &count, images_.data());

    if (formatChanged && renderPass_) {
        vkDestroyRenderPass(context_.device(), renderPass_, nullptr);
        renderPass_ = VK_NULL_HANDLE;
    }
    if (!renderPass_) {
        // The panels go over what the blits left: load, and come in from the copies.
        VkAttachmentDescription color{};
        color.format = format_;
        color.samples = VK_SAMPLE_COUNT_1_BIT;
        color.loadOp = VK_ATTACHMENT_LOAD_OP_LOAD;
        color.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
        color.stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
        color.stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
        color.initialLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
        color.finalLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
        VkAttachmentReference ref{0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
        VkSubpassDescription subpass{};
        subpass.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
        subpass.colorAttachmentCount = 1;
        subpass.pColorAttachments = &ref;
        VkRenderPassCreateInfo rp{VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO};
        rp.attachmentCount = 1;
        rp.pAttachments = &color;
        rp.subpassCount = 1;
        rp.pSubpasses = &subpass;
        gpu::check(vkCreateRenderPass(context_.device(), &rp, nullptr, &renderPass_), "vkCreateRenderPass");
    }
    for (VkImage image : images_) {
        VkImageViewCreateInfo v{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
        v.image = image;
        v.viewType = VK_IMAGE_VIEW_TYPE_2D;
        v.format = format_;
        v.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
        VkImageView view = VK_NULL_HANDLE;
        gpu::check(vkCreateImageView(context_.device(), &v, nullptr, &view), "vkCreateImageView");
        views_.push_back(view);
        framebuffers_.push_back(framebufferFor(view));
        VkSemaphoreCreateInfo s{VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO};
        VkSemaphore semaphore = VK_NULL_HANDLE;
        gpu::check(vkCreateSemaphore(context_.device(), &s, nullptr, &semaphore), "vkCreateSemaphore");
        renderDone_.push_back(semaphore);
    }
    if (imguiReady_) ImGui_ImplVulkan_SetMinImageCount(info.minImageCount);
    swapchainStale_ = false;
}

// The panels' render pass over `view`, at the window's size.
VkFramebuffer Presenter::framebufferFor(VkImageView view) const
{
    VkFramebufferCreateInfo fb{VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO};
    fb.renderPass = renderPass_;
    fb.attachmentCount = 1;
    fb.pAttachments = &view;
    fb.width = extent_.width;
    fb.height = extent_.height;
    fb.layers = 1;
    VkFramebuffer framebuffer = VK_NULL_HANDLE;
    gpu::check(vkCreateFramebuffer(context_.device(), &fb, nullptr, &framebuffer), "vkCreateFramebuffer");
    return framebuffer;
}

void Presenter::destroySwapchain()
{
    VkDevice device = context_.device();
    for (VkFramebuffer f : framebuffers_) vkDestroyFramebuffer(device, f, nullptr);
    for (VkImageView v : views_) vkDestroyImageView(device, v, nullptr);
    for (VkSemaphore s : renderDone_) vkDestroySemaphore(device, s, nullptr);
    framebuffers_.clear();
    views_.clear();
    renderDone_.clear();
    images_.clear();
    if (swapchain_) vkDestroySwapchainKHR(device, swapchain_, nullptr);
    swapchain_ = VK_NULL_HANDLE;
    // The panels' layer has the swapchain's size and format.
    if (uiFramebuffer_) vkDestroyFramebuffer(device, uiFramebuffer_, nullptr);
    uiFramebuffer_ = VK_NULL_HANDLE;
    uiLayer_ = {};
    uiLayerRects_.clear();
}

void Presenter::initImGui()
{
    VkDescriptorPoolSize sizes[] = {{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 16}};
    VkDescriptorPoolCreateInfo poolInfo{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
    poolInfo.flags = VK_DESCRIPTOR_POOL_CREATE_FREE_DESCRIPTOR_SET_BIT;
    poolInfo.maxSets = 16;
    poolInfo.poolSizeCount = 1;
    poolInfo.pPoolSizes = sizes;
    gpu::check(vkCreateDescriptorPool(context_.device(), &poolInfo, nullptr, &imguiPool_), "vkCreateDescriptorPool");
    if (!renderPass_) throw GpuError("the window has no size to draw into");
    ImGui_ImplVulkan_InitInfo init{};
    init.Instance = context_.instance();
    init.PhysicalDevice = context_.physicalDevice();
    init.Device = context_.device();
    init.QueueFamily = context_.queueFamily();
    init.Queue = context_.queue();
    init.DescriptorPool = imguiPool_;
    init.Subpass = 0;
    init.MinImageCount = 2;
    init.ImageCount = uint32_t(std::max<size_t>(images_.size(), 2));
    init.MSAASamples = VK_SAMPLE_COUNT_1_BIT;
    init.CheckVkResultFn = checkImGuiResult;
    if (!ImGui_ImplVulkan_Init(&init, renderPass_)) throw GpuError("Dear ImGui's Vulkan backend did not initialise");
    imguiReady_ = true;
    context_.submitAndWait([](VkCommandBuffer cmd) { ImGui_ImplVulkan_CreateFontsTexture(cmd); });
    ImGui_ImplVulkan_DestroyFontUploadObjects();
}

void Presenter::setVsync(bool vsync)
{
    if (vsync == vsync_) return;
    vsync_ = vsync;
    swapchainStale_ = true;
}

// The render pass that clears `uncovered` to the background and draws the panels, over
// the part of `framebuffer` those cover (the window's image, or the panels' layer).
void Presenter::recordUi(VkFramebuffer framebuffer, const std::vector<VkRect2D>& uncovered, ImDrawData* ui,
                         const float background[3])
{
    VkRect2D area{};
    bool any = false;
    auto include = [&](const VkRect2D& r) {
        if (r.extent.width == 0 || r.extent.height == 0) return;
        area = any ? boundingRect(area, r) : r;
        any = true;
    };
    for (const VkRect2D& r : uncovered) include(r);
    if (ui) include(drawnArea(*ui, extent_));
    if (!any) return;
    VkRenderPassBeginInfo rp{VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO};
    rp.renderPass = renderPass_;
    rp.framebuffer = framebuffer;
    rp.renderArea = area;
    vkCmdBeginRenderPass(cmd_, &rp, VK_SUBPASS_CONTENTS_INLINE);
    if (!uncovered.empty()) {
        VkClearAttachment clear{VK_IMAGE_ASPECT_COLOR_BIT, 0, {}};
        clear.clearValue.color = {{background[0], background[1], background[2], 1.0f}};
        std::vector<VkClearRect> rects;
        for (const VkRect2D& r : uncovered) rects.push_back({r, 0, 1});
        vkCmdClearAttachments(cmd_, 1, &clear, uint32_t(rects.size()), rects.data());
    }
    if (ui) ImGui_ImplVulkan_RenderDrawData(ui, cmd_);
    vkCmdEndRenderPass(cmd_);
}

// Draws the background and the panels into the panels' layer (made at the window's size
// on first use), and leaves it as a copy source.
void Presenter::drawUiLayer(const std::vector<VkRect2D>& uncovered, ImDrawData* ui, const float background[3])
{
    if (!uiLayer_.handle()) {
        gpu::ImageDesc desc;
        desc.width = extent_.width;
        desc.height = extent_.height;
        desc.format = format_;
        desc.usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
        desc.name = "viewer panels";
        uiLayer_ = gpu::Image(context_, desc);
        uiFramebuffer_ = framebufferFor(uiLayer_.view());
    }
    // Everything the copies take is drawn again: nothing of the last contents is kept.
    barrier(cmd_, uiLayer_.handle(), VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
            VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, 0, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
            VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT);
    recordUi(uiFramebuffer_, uncovered, ui, background);
    barrier(cmd_, uiLayer_.handle(), VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
            VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
            VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_READ_BIT);
    uiLayerRects_ = uncovered;
}

void Presenter::present(const std::vector<ViewBlit>& views, ImDrawData* ui, bool uiChanged, const float background[3],
                        std::vector<uint8_t>* screenshot)
{
    VkDevice device = context_.device();
    gpu::check(vkWaitForFences(device, 1, &done_, VK_TRUE, UINT64_MAX), "vkWaitForFences");
    if (timed_) {
        timed_ = false;
        lastTimes_ = {};
        for (const gpu::ScopeTime& scope : timer_->collect()) {
            (scope.name == "views" ? lastTimes_.viewsMs : lastTimes_.panelsMs) = scope.gpuMs;
            lastTimes_.valid = true;
        }
    }
    int width = 0, height = 0;
    glfwGetFramebufferSize(window_, &width, &height);
    if (swapchainStale_ || !swapchain_ || uint32_t(width) != extent_.width || uint32_t(height) != extent_.height) {
        if (width == 0 || height == 0) return;  // minimised
        vkDeviceWaitIdle(device);
        destroySwapchain();
        createSwapchain();
        if (!swapchain_) return;
    }

    uint32_t index = 0;
    VkResult acquired = vkAcquireNextImageKHR(device, swapchain_, UINT64_MAX, acquired_, VK_NULL_HANDLE, &index);
    if (acquired == VK_ERROR_OUT_OF_DATE_KHR) {
        swapchainStale_ = true;
        return;
    }
    if (acquired != VK_SUBOPTIMAL_KHR) gpu::check(acquired, "vkAcquireNextImageKHR");
    gpu::check(vkResetFences(device, 1, &done_), "vkResetFences");

    VkImage target = images_[index];
    gpu::check(vkResetCommandBuffer(cmd_, 0), "vkResetCommandBuffer");
    VkCommandBufferBeginInfo begin{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    gpu::check(vkBeginCommandBuffer(cmd_, &begin), "vkBeginCommandBuffer");
    if (!timer_) timer_ = std::make_unique<gpu::GpuTimer>(context_, 2);
    timer_->beginFrame(cmd_);
    const uint32_t viewsScope = timer_->beginScope(cmd_, "views");
    // Nothing of the last image is kept: the views are copied in, the rest is cleared in
    // the render pass below (only there: a full clear of a large window costs more on a
    // CPU rasterizer than the panels).
    barrier(cmd_, target, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
            VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, 0, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
            VK_ACCESS_2_TRANSFER_WRITE_BIT);
    for (const ViewBlit& view : views) {
        if (!view.image || view.target.extent.width == 0 || view.target.extent.height == 0) continue;
        // The image as the frame left it -> blit source -> back, so that the next frame of
        // the graph (or the next upload) finds it as it left it.
        const gpu::ImageAccess before{view.layout, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_WRITE_BIT};
        const gpu::ImageAccess source{VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, VK_PIPELINE_STAGE_2_BLIT_BIT,
                                      VK_ACCESS_2_TRANSFER_READ_BIT};
        const gpu::ImageAccess after{view.layout, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                                     VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT};
        if (view.layout != VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL) gpu::transition(cmd_, *view.image, before, source);
        VkImageBlit blit{};
        blit.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        const VkRect2D whole{{0, 0}, {view.image->desc().width, view.image->desc().height}};
        const VkRect2D& src = view.source.extent.width && view.source.extent.height ? view.source : whole;
        blit.srcOffsets[0] = {src.offset.x, src.offset.y, 0};
        blit.srcOffsets[1] = {src.offset.x + int32_t(src.extent.width), src.offset.y + int32_t(src.extent.height), 1};
        blit.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        const VkRect2D& r = view.target;
        blit.dstOffsets[0] = {r.offset.x, r.offset.y, 0};
        blit.dstOffsets[1] = {r.offset.x + int32_t(r.extent.width), r.offset.y + int32_t(r.extent.height), 1};
        // One image texel per window pixel is copied exactly; a scaled view is filtered.
        const bool exact = r.extent.width == src.extent.width && r.extent.height == src.extent.height;
        vkCmdBlitImage(cmd_, view.image->handle(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, target,
                       VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &blit, exact ? VK_FILTER_NEAREST : VK_FILTER_LINEAR);
        if (view.layout != VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL) gpu::transition(cmd_, *view.image, source, after);
    }
    timer_->endScope(cmd_, viewsScope);
    // What is not a view: the background and the panels. They are drawn into the panels'
    // layer when they change and copied from there every frame (a copy costs a fraction
    // of drawing the panels' blended triangles on a CPU rasterizer). What Dear ImGui
    // draws over a view (the pixel inspector's tooltip, the split line, a popup) is drawn
    // over the copied frame, every frame: its draw lists from the first that reaches into
    // a view on, so that their order is kept.
    const uint32_t panelsScope = timer_->beginScope(cmd_, "panels");
    const std::vector<VkRect2D> uncovered = uncoveredRects(views);
    std::optional<VkRect2D> viewBox;  // what uncoveredRects leaves out
    for (const ViewBlit& view : views) {
        if (view.image && view.target.extent.width > 0 && view.target.extent.height > 0)
            viewBox = viewBox ? boundingRect(*viewBox, view.target) : view.target;
    }
    std::vector<ImDrawList*> lists = ui ? std::vector<ImDrawList*>(ui->CmdLists, ui->CmdLists + ui->CmdListsCount)
                                        : std::vector<ImDrawList*>{};
    const bool layered = panelLayer_ && !uncovered.empty();
    const size_t layerLists = layered && ui ? listsInLayer(*ui, viewBox, extent_) : 0;
    if (layered) {
        if (uiChanged || !sameRects(uncovered, uiLayerRects_) || !uiLayer_.handle()) {
            const std::vector<ImDrawList*> inLayer(lists.begin(), lists.begin() + ptrdiff_t(layerLists));
            ImDrawData layer = ui ? subset(*ui, inLayer) : ImDrawData{};
            drawUiLayer(uncovered, ui ? &layer : nullptr, background);
        }
        std::vector<VkImageCopy> copies;
        for (const VkRect2D& r : uncovered) {
            VkImageCopy c{};
            c.srcSubresource = c.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
            c.srcOffset = c.dstOffset = {r.offset.x, r.offset.y, 0};
            c.extent = {r.extent.width, r.extent.height, 1};
            copies.push_back(c);
        }
        vkCmdCopyImage(cmd_, uiLayer_.handle(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, target,
                       VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, uint32_t(copies.size()), copies.data());
    }
    barrier(cmd_, target, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
            VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
            VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
            VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT);
    if (layered) {
        if (layerLists < lists.size()) {
            const std::vector<ImDrawList*> overViews(lists.begin() + ptrdiff_t(layerLists), lists.end());
            ImDrawData over = subset(*ui, overViews);
            recordUi(framebuffers_[index], {}, &over, background);
        }
    } else {
        recordUi(framebuffers_[index], uncovered, ui, background);  // no layer: every panel drawn over the frame
        uiLayerRects_.clear();  // the layer missed these panels: drawn again when next used
    }
    timer_->endScope(cmd_, panelsScope);

    const bool readBack = screenshot && canReadBack_;
    if (readBack) {
        const VkDeviceSize bytes = VkDeviceSize(extent_.width) * extent_.height * 4;
        if (readBack_.size() < bytes) {
            readBack_ = gpu::Buffer(context_, bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT, true, "viewer window (read-back)");
        }
        barrier(cmd_, target, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
                VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_READ_BIT);
        VkBufferImageCopy region{};
        region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        region.imageExtent = {extent_.width, extent_.height, 1};
        vkCmdCopyImageToBuffer(cmd_, target, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, readBack_.handle(), 1, &region);
        barrier(cmd_, target, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, VK_IMAGE_LAYOUT_PRESENT_SRC_KHR,
                VK_PIPELINE_STAGE_2_COPY_BIT, 0, VK_PIPELINE_STAGE_2_NONE, 0);
        gpu::memoryBarrier(cmd_, {VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT},
                           {VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT});
    } else {
        barrier(cmd_, target, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_PRESENT_SRC_KHR,
                VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
                VK_PIPELINE_STAGE_2_NONE, 0);
    }
    gpu::check(vkEndCommandBuffer(cmd_), "vkEndCommandBuffer");

    VkSemaphoreSubmitInfo wait{VK_STRUCTURE_TYPE_SEMAPHORE_SUBMIT_INFO};
    wait.semaphore = acquired_;
    wait.stageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
    VkSemaphoreSubmitInfo signal{VK_STRUCTURE_TYPE_SEMAPHORE_SUBMIT_INFO};
    signal.semaphore = renderDone_[index];
    signal.stageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
    VkCommandBufferSubmitInfo cmdInfo{VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO};
    cmdInfo.commandBuffer = cmd_;
    VkSubmitInfo2 submit{VK_STRUCTURE_TYPE_SUBMIT_INFO_2};
    submit.waitSemaphoreInfoCount = 1;
    submit.pWaitSemaphoreInfos = &wait;
    submit.commandBufferInfoCount = 1;
    submit.pCommandBufferInfos = &cmdInfo;
    submit.signalSemaphoreInfoCount = 1;
    submit.pSignalSemaphoreInfos = &signal;
    gpu::check(vkQueueSubmit2(context_.queue(), 1, &submit, done_), "vkQueueSubmit2 (viewer)");
    timed_ = true;

    if (readBack) {
        gpu::check(vkWaitForFences(device, 1, &done_, VK_TRUE, UINT64_MAX), "vkWaitForFences");
        const size_t bytes = size_t(extent_.width) * extent_.height * 4;
        screenshot->resize(bytes);
        std::memcpy(screenshot->data(), readBack_.mapped(), bytes);
        // The window's BGRA to the PNG's RGBA.
        if (format_ == VK_FORMAT_B8G8R8A8_UNORM || format_ == VK_FORMAT_B8G8R8A8_SRGB) {
            for (size_t i = 0; i < bytes; i += 4) std::swap((*screenshot)[i], (*screenshot)[i + 2]);
        }
        for (size_t i = 3; i < bytes; i += 4) (*screenshot)[i] = 255;
    } else if (screenshot) {
        screenshot->clear();
    }

    VkPresentInfoKHR presentInfo{VK_STRUCTURE_TYPE_PRESENT_INFO_KHR};
    presentInfo.waitSemaphoreCount = 1;
    presentInfo.pWaitSemaphores = &renderDone_[index];
    presentInfo.swapchainCount = 1;
    presentInfo.pSwapchains = &swapchain_;
    presentInfo.pImageIndices = &index;
    const VkResult presented = vkQueuePresentKHR(context_.queue(), &presentInfo);
    if (presented == VK_ERROR_OUT_OF_DATE_KHR || presented == VK_SUBOPTIMAL_KHR) {
        swapchainStale_ = true;
    } else {
        gpu::check(presented, "vkQueuePresentKHR");
    }
}

} // namespace penumbra::viewer
