#include "penumbra/render/Casters.h"

#include <cstddef>

namespace penumbra::render {

void Casters::draw(VkCommandBuffer cmd, const CasterView& /*view*/, DrawFilter filter,
                   const std::function<void(const gpu::Image& texture)>& bindTexture) const
{
    // Culling mode "none": every caster. The visibility service of issue 6 narrows the
    // list per view here, behind this one entry point.
    scene_->draw(cmd, filter, bindTexture);
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
