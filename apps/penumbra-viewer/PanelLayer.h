#pragma once
// The geometry behind the panels' layer (Presenter::present): which window pixels Dear
// ImGui's draw lists cover, and which lists can be drawn once into a layer and copied
// from there instead of being drawn over the frame every time. No window and no device:
// the tests check it on Dear ImGui's own draw data.
#include <imgui.h>
#include <vulkan/vulkan.h>

#include <cstddef>
#include <optional>
#include <vector>

namespace penumbra::viewer {

bool intersects(const VkRect2D& a, const VkRect2D& b);  // a shared pixel; empty rectangles share none
VkRect2D boundingRect(const VkRect2D& a, const VkRect2D& b);
bool sameRects(const std::vector<VkRect2D>& a, const std::vector<VkRect2D>& b);

// The window pixels (framebuffer pixels, within `extent`) that `lists` of `ui` draw into:
// the union over their draw commands of the bounds of the triangles each draws, clipped
// by its clip rectangle. Clip rectangles alone bound nothing: a window's frame is drawn
// with the whole display's.
VkRect2D drawnArea(const ImDrawData& ui, const std::vector<ImDrawList*>& lists, VkExtent2D extent);
VkRect2D drawnArea(const ImDrawData& ui, VkExtent2D extent);  // all its lists

// How many of `ui`'s lists, from the first, draw nowhere into `views` (the views'
// bounding box; none: every list): those go into the layer. The list that first reaches
// into a view and all after it are drawn over the frame, so that the order is kept.
size_t listsInLayer(const ImDrawData& ui, const std::optional<VkRect2D>& views, VkExtent2D extent);

// `all` drawing only `lists` (which must outlive the result).
ImDrawData subset(const ImDrawData& all, const std::vector<ImDrawList*>& lists);

} // namespace penumbra::viewer
