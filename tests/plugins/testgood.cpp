// The test suite's well-formed plugin: one reflected parameter of every type, and a
// technique that is trivial but real - one transfer pass that clears the light's
// visibility image V_l to `fill` (or to 1 with mode "unshadowed"). It also reports the
// parameter values its factory received (penumbra_testgood_received), so that tests can
// check what a plugin sees end to end: config JSON -> ParamValues -> plugin.
#include "penumbra/graph/PassContext.h"
#include "penumbra/plugin/Plugin.h"
#include "penumbra/plugin/Technique.h"

#include <nlohmann/json.hpp>

#include <iterator>
#include <string>

namespace {

using namespace penumbra;

const char* const kModes[] = {"clear", "unshadowed"};

const plugin::ParamSpec kParams[] = {
    {"enabled", plugin::ParamType::Bool, 1, 0, 1, "", "register the clear pass at all"},
    {"kernel", plugin::ParamType::Int, 5, 1, 15, "texels", "a kernel width, unused"},
    {"fill", plugin::ParamType::Float, 0.5, 0, 1, "", "the value V_l is cleared to"},
    {"bias", plugin::ParamType::Float, 0.01, -1, 1, "world", "a signed offset, unused"},
    {"mode", plugin::ParamType::Enum, 0, 0, 0, "", "clear to fill, or to 1 (unshadowed)", kModes, std::size(kModes)},
};

std::string& received()
{
    static std::string json;
    return json;
}

class FillTechnique final : public plugin::Technique {
public:
    explicit FillTechnique(const plugin::TechniqueSetup& setup)
        : enabled_(setup.params.getBool("enabled")),
          fill_(setup.params.getEnum("mode") == "unshadowed" ? 1.0f : setup.params.getFloat("fill"))
    {
        received() = nlohmann::json{{"enabled", enabled_},
                                    {"kernel", setup.params.getInt("kernel")},
                                    {"fill", setup.params.getFloat("fill")},
                                    {"bias", setup.params.getFloat("bias")},
                                    {"mode", setup.params.getEnum("mode")},
                                    {"mode_index", setup.params.getEnumIndex("mode")},
                                    {"light", setup.lightIndex}}
                         .dump();
    }

    void update(const scene::Light&, const scene::Aabb&) override {}

    void registerPasses(graph::RenderGraph& graph, const plugin::LightPassIo& io) override
    {
        if (!enabled_) return;
        const std::string visibility = io.visibility;
        const float fill = fill_;
        graph.addPass(io.local("fill"), graph::QueueKind::Transfer)
            .write(visibility, graph::Usage::TransferDst)
            .execute([visibility, fill](graph::PassContext& pass) {
                const VkClearColorValue color{{fill, fill, fill, fill}};
                const VkImageSubresourceRange all{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
                vkCmdClearColorImage(pass.cmd(), pass.image(visibility).handle(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                                     &color, 1, &all);
            });
    }

private:
    bool enabled_;
    float fill_;
};

} // namespace

// The SDK's entry-point macro, as a plugin uses it (the other test plugins build their
// entries by hand, malformed on purpose).
PENUMBRA_DEFINE_PLUGIN("testgood", "1.2.0", "test plugin: clears V_l to a constant", kParams, FillTechnique)

// The parameters the last technique was created with, as JSON ("" before the first).
PENUMBRA_PLUGIN_EXPORT const char* penumbra_testgood_received() { return received().c_str(); }
