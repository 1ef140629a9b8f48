#include "penumbra/render/Casters.h"

#include "render/CasterCulling.h"

#include <algorithm>
#include <cstddef>
#include <utility>

namespace penumbra::render {

std::string lightState(uint32_t light) { return "light" + std::to_string(light); }

void Casters::draw(VkCommandBuffer cmd, const CasterView& view, DrawFilter filter,
                   const std::function<void(const gpu::Image& texture)>& bindTexture) const
{
    if (std::find(drawnViews_.begin(), drawnViews_.end(), view) == drawnViews_.end()) drawnViews_.push_back(view);
    if (!culling_) {
        scene_->draw(cmd, filter, bindTexture);
        return;
    }
    // The service culls the view on its first draw of the frame (its own submissions,
    // waited for: the caster list is exact for this frame) and keeps the list for the
    // view's other draws.
    const std::vector<uint8_t>* casters = culling_->casters(view);
    culling_->countDraw(scene_->draw(cmd, filter, bindTexture, casters));
}

std::vector<CasterView> Casters::takeDrawnViews() { return std::exchange(drawnViews_, {}); }

const scene::Aabb* Casters::focus() const { return culling_ ? culling_->focus() : nullptr; }

std::optional<VkRect2D> Casters::readArea(const CasterView& view) const
{
    return culling_ ? culling_->readArea(view) : std::nullopt;
}

void Casters::countRenderedTexels(uint64_t texels) const
{
    if (culling_) culling_->countRenderedTexels(texels);
}

gpu::VertexLayout Casters::positionLayout() const
{
    return {scene_->vertexStride(), {{0, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(scene::Vertex, position)}}};
}

gpu::VertexLayout Casters::positionUvLayout() const
{
    gpu::VertexLayout layout = positionLayout();
    layout.attributes.push_back({2, 0, VK_FORMAT_R32G32_SFLOAT, offsetof(scene::Vertex, uv)});
    return layout;
}

} // namespace penumbra::render
