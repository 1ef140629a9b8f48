#include "penumbra/plugin/ClearPass.h"

#include "penumbra/gpu/Resources.h"
#include "penumbra/graph/PassContext.h"

#include <utility>
#include <vector>

namespace penumbra::plugin {

struct ClearPass::Targets {
    std::vector<std::pair<std::string, VkClearColorValue>> images;
    std::vector<std::pair<std::string, uint32_t>> buffers;
};

ClearPass::ClearPass(graph::RenderGraph& graph, std::string name)
    : pass_(graph.addPass(std::move(name), graph::QueueKind::Transfer)), targets_(std::make_shared<Targets>())
{
    pass_.execute([targets = targets_](graph::PassContext& pass) {
        const VkImageSubresourceRange all{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, VK_REMAINING_ARRAY_LAYERS};
        for (const auto& [name, value] : targets->images)
            vkCmdClearColorImage(pass.cmd(), pass.image(name).handle(), pass.layout(name), &value, 1, &all);
        for (const auto& [name, word] : targets->buffers)
            vkCmdFillBuffer(pass.cmd(), pass.buffer(name).handle(), 0, VK_WHOLE_SIZE, word);
    });
}

ClearPass& ClearPass::image(std::string_view image, VkClearColorValue value)
{
    pass_.write(image, graph::Usage::TransferDst);
    targets_->images.emplace_back(std::string(image), value);
    return *this;
}

ClearPass& ClearPass::buffer(std::string_view buffer, uint32_t word)
{
    pass_.write(buffer, graph::Usage::TransferDst);
    targets_->buffers.emplace_back(std::string(buffer), word);
    return *this;
}

ClearPass& ClearPass::dependsOn(std::string_view state)
{
    pass_.dependsOn(state);
    return *this;
}

} // namespace penumbra::plugin
