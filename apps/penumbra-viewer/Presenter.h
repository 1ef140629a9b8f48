#pragma once
// The viewer's window on the screen: a GLFW window's Vulkan surface and swapchain, and the
// one command buffer a shown frame takes — the frame's images blitted into the view's
// rectangles, then the background and the Dear ImGui panels copied from their layer (drawn
// into it in a render pass when they changed) and what of them lies over a view drawn
// over it, then present.
// It owns no renderer: the images it shows are the render graph's (the colour image after
// FrameRenderer::renderFrame) or ones it uploads (a mapped debug image, a difference).
#include "penumbra/gpu/Context.h"
#include "penumbra/gpu/GpuTimer.h"
#include "penumbra/gpu/Resources.h"

#include <vulkan/vulkan.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <vector>

struct GLFWwindow;
struct ImDrawData;

namespace penumbra::viewer {

// One image shown in a rectangle of the window (scaled, aspect kept by the caller).
struct ViewBlit {
    const gpu::Image* image = nullptr;
    VkImageLayout layout = VK_IMAGE_LAYOUT_UNDEFINED;  // the layout it is in, and is left in
    VkRect2D target{};                                 // window pixels
    VkRect2D source{};                                 // image pixels; an empty one: the whole image
};

// RGBA8 pixels the presenter uploads and shows: a debug image mapped to colour, a
// difference image. Re-uploaded only when set again.
class UploadedImage {
public:
    UploadedImage(gpu::Context& context, const char* name) : context_(context), name_(name) {}
    // Copies `rgba` (rows top first) to the image through a staging copy, and waits.
    void set(uint32_t width, uint32_t height, const std::vector<uint8_t>& rgba);
    bool empty() const { return image_.handle() == VK_NULL_HANDLE; }
    const gpu::Image& image() const { return image_; }
    static constexpr VkImageLayout kLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;

private:
    gpu::Context& context_;
    const char* name_;
    gpu::Image image_;
    gpu::Buffer staging_;
};

// The GPU time of the last shown frame's parts (timestamps around them).
struct PresentTimes {
    bool valid = false;
    double viewsMs = 0.0;   // the views blitted into the window
    double panelsMs = 0.0;  // the background and the panels: drawn, or copied from their layer
};

class Presenter {
public:
    // Creates the surface and the swapchain (and initialises ImGui's Vulkan backend, whose
    // ImGui context and GLFW backend the caller set up). Throws GpuError naming what the
    // window system or the device lacks.
    Presenter(gpu::Context& context, GLFWwindow* window, bool vsync);
    ~Presenter();
    Presenter(const Presenter&) = delete;
    Presenter& operator=(const Presenter&) = delete;

    // Shows one frame: clears to `background`, blits `views`, draws `ui` (may be null) and
    // presents. Recreates the swapchain when the window's size changed (a frame of size 0,
    // a minimised window, is skipped). With `screenshot`, the composed window image is read
    // back to RGBA8 rows (top first) before it is presented.
    // `uiChanged`: `ui` is not the draw data of the last call. Panels drawn outside every
    // view are kept in a layer of their own and drawn again only when they changed or the
    // views moved; between, the layer is copied into the window.
    void present(const std::vector<ViewBlit>& views, ImDrawData* ui, bool uiChanged, const float background[3],
                 std::vector<uint8_t>* screenshot = nullptr);
    // Off: the panels are drawn into the window every frame, as without a layer (to measure
    // what the layer saves).
    void setPanelLayer(bool on) { panelLayer_ = on; }
    bool panelLayer() const { return panelLayer_; }
    // The last frame whose commands finished (read at the next present()).
    const PresentTimes& lastTimes() const { return lastTimes_; }

    void setVsync(bool vsync);
    bool vsync() const { return vsync_; }
    VkExtent2D extent() const { return extent_; }
    VkFormat format() const { return format_; }

private:
    void release();
    std::vector<VkRect2D> uncoveredRects(const std::vector<ViewBlit>& views) const;
    void createSwapchain();
    void destroySwapchain();
    void initImGui();
    VkFramebuffer framebufferFor(VkImageView view) const;
    void recordUi(VkFramebuffer framebuffer, const std::vector<VkRect2D>& uncovered, ImDrawData* ui,
                  const float background[3]);
    void drawUiLayer(const std::vector<VkRect2D>& uncovered, ImDrawData* ui, const float background[3]);

    gpu::Context& context_;
    GLFWwindow* window_;
    bool vsync_;
    bool swapchainStale_ = false;
    VkSurfaceKHR surface_ = VK_NULL_HANDLE;
    VkSwapchainKHR swapchain_ = VK_NULL_HANDLE;
    VkFormat format_ = VK_FORMAT_UNDEFINED;
    VkPresentModeKHR presentMode_ = VK_PRESENT_MODE_FIFO_KHR;
    VkExtent2D extent_{};
    bool canReadBack_ = false;  // the swapchain images allow TRANSFER_SRC (screenshots)
    std::vector<VkImage> images_;
    std::vector<VkImageView> views_;
    std::vector<VkFramebuffer> framebuffers_;
    std::vector<VkSemaphore> renderDone_;  // one per swapchain image: present waits on it
    VkRenderPass renderPass_ = VK_NULL_HANDLE;
    VkCommandPool pool_ = VK_NULL_HANDLE;
    VkCommandBuffer cmd_ = VK_NULL_HANDLE;
    VkSemaphore acquired_ = VK_NULL_HANDLE;
    VkFence done_ = VK_NULL_HANDLE;
    VkDescriptorPool imguiPool_ = VK_NULL_HANDLE;
    bool imguiReady_ = false;
    gpu::Buffer readBack_;
    // The background and the panels outside the views, as last drawn (present()).
    gpu::Image uiLayer_;
    VkFramebuffer uiFramebuffer_ = VK_NULL_HANDLE;
    std::vector<VkRect2D> uiLayerRects_;  // the window's pixels it holds; empty: none
    bool panelLayer_ = true;
    std::unique_ptr<gpu::GpuTimer> timer_;
    bool timed_ = false;  // a submitted frame's timestamps wait to be read
    PresentTimes lastTimes_;
};

} // namespace penumbra::viewer
