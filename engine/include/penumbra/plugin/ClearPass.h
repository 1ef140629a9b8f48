#pragma once
// A pass that sets graph images and buffers to a constant every frame: a sum's zero, an
// empty list's head, counters' zero, an unshadowed light's V = 1.
#include "penumbra/graph/RenderGraph.h"

#include <vulkan/vulkan.h>

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

namespace penumbra::plugin {

class ClearPass {
public:
    // Declares the transfer pass `name`; image() and buffer() add what it clears (each a
    // TransferDst write of the pass).
    ClearPass(graph::RenderGraph& graph, std::string name);

    // Every texel of the colour image `image` to `value`.
    ClearPass& image(std::string_view image, VkClearColorValue value);
    // Every 32-bit word of `buffer` to `word`.
    ClearPass& buffer(std::string_view buffer, uint32_t word);
    // The clear starts what passes that depend on `state` build on (a list's heads, a
    // sum): declared with their state, it is kept with them, and runs again whenever one
    // of them does (graph::PassBuilder::dependsOn).
    ClearPass& dependsOn(std::string_view state);

private:
    struct Targets;
    graph::PassBuilder pass_;
    std::shared_ptr<Targets> targets_;  // shared with the pass's callback
};

} // namespace penumbra::plugin
