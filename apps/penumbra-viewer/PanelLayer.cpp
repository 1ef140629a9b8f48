#include "PanelLayer.h"

#include <algorithm>
#include <cmath>

namespace penumbra::viewer {

bool intersects(const VkRect2D& a, const VkRect2D& b)
{
    return a.extent.width > 0 && a.extent.height > 0 && b.extent.width > 0 && b.extent.height > 0 &&
           a.offset.x < b.offset.x + int32_t(b.extent.width) && b.offset.x < a.offset.x + int32_t(a.extent.width) &&
           a.offset.y < b.offset.y + int32_t(b.extent.height) && b.offset.y < a.offset.y + int32_t(a.extent.height);
}

VkRect2D boundingRect(const VkRect2D& a, const VkRect2D& b)
{
    const int32_t x0 = std::min(a.offset.x, b.offset.x), y0 = std::min(a.offset.y, b.offset.y);
    const int32_t x1 = std::max(a.offset.x + int32_t(a.extent.width), b.offset.x + int32_t(b.extent.width));
    const int32_t y1 = std::max(a.offset.y + int32_t(a.extent.height), b.offset.y + int32_t(b.extent.height));
    return {{x0, y0}, {uint32_t(x1 - x0), uint32_t(y1 - y0)}};
}

bool sameRects(const std::vector<VkRect2D>& a, const std::vector<VkRect2D>& b)
{
    return std::equal(a.begin(), a.end(), b.begin(), b.end(), [](const VkRect2D& x, const VkRect2D& y) {
        return x.offset.x == y.offset.x && x.offset.y == y.offset.y && x.extent.width == y.extent.width &&
               x.extent.height == y.extent.height;
    });
}

VkRect2D drawnArea(const ImDrawData& ui, const std::vector<ImDrawList*>& lists, VkExtent2D extent)
{
    float x0 = 1e30f, y0 = 1e30f, x1 = -1e30f, y1 = -1e30f;
    const ImVec2 scale = ui.FramebufferScale, origin = ui.DisplayPos;
    for (const ImDrawList* list : lists) {
        for (const ImDrawCmd& c : list->CmdBuffer) {
            if (c.ElemCount == 0 || c.UserCallback) continue;
            float cx0 = 1e30f, cy0 = 1e30f, cx1 = -1e30f, cy1 = -1e30f;
            for (unsigned int e = 0; e < c.ElemCount; ++e) {
                const unsigned int i = c.IdxOffset + e;
                if (i >= unsigned(list->IdxBuffer.Size)) break;
                const unsigned int v = c.VtxOffset + list->IdxBuffer[int(i)];
                if (v >= unsigned(list->VtxBuffer.Size)) continue;
                const ImVec2 p = list->VtxBuffer[int(v)].pos;
                cx0 = std::min(cx0, p.x);
                cy0 = std::min(cy0, p.y);
                cx1 = std::max(cx1, p.x);
                cy1 = std::max(cy1, p.y);
            }
            x0 = std::min(x0, (std::max(cx0, c.ClipRect.x) - origin.x) * scale.x);
            y0 = std::min(y0, (std::max(cy0, c.ClipRect.y) - origin.y) * scale.y);
            x1 = std::max(x1, (std::min(cx1, c.ClipRect.z) - origin.x) * scale.x);
            y1 = std::max(y1, (std::min(cy1, c.ClipRect.w) - origin.y) * scale.y);
        }
    }
    const int32_t ax = std::clamp(int32_t(std::floor(x0)), 0, int32_t(extent.width));
    const int32_t ay = std::clamp(int32_t(std::floor(y0)), 0, int32_t(extent.height));
    const int32_t bx = std::clamp(int32_t(std::ceil(x1)), 0, int32_t(extent.width));
    const int32_t by = std::clamp(int32_t(std::ceil(y1)), 0, int32_t(extent.height));
    if (bx <= ax || by <= ay) return {};
    return {{ax, ay}, {uint32_t(bx - ax), uint32_t(by - ay)}};
}

VkRect2D drawnArea(const ImDrawData& ui, VkExtent2D extent)
{
    return drawnArea(ui, std::vector<ImDrawList*>(ui.CmdLists, ui.CmdLists + ui.CmdListsCount), extent);
}

size_t listsInLayer(const ImDrawData& ui, const std::optional<VkRect2D>& views, VkExtent2D extent)
{
    size_t n = 0;
    while (n < size_t(ui.CmdListsCount) && !(views && intersects(drawnArea(ui, {ui.CmdLists[n]}, extent), *views))) ++n;
    return n;
}

ImDrawData subset(const ImDrawData& all, const std::vector<ImDrawList*>& lists)
{
    ImDrawData part = all;
    part.CmdLists = const_cast<ImDrawList**>(lists.data());
    part.CmdListsCount = int(lists.size());
    part.TotalVtxCount = part.TotalIdxCount = 0;
    for (const ImDrawList* list : lists) {
        part.TotalVtxCount += list->VtxBuffer.Size;
        part.TotalIdxCount += list->IdxBuffer.Size;
    }
    return part;
}

} // namespace penumbra::viewer
