// Text and Graphviz views of a compiled graph (`penumbra graph`).
#include "penumbra/graph/RenderGraph.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <vulkan/vulkan.hpp>
#include <vulkan/vulkan_to_string.hpp>

namespace penumbra::graph {

namespace {

const char* queueName(QueueKind queue)
{
    switch (queue) {
    case QueueKind::Graphics: return "graphics";
    case QueueKind::Compute: return "compute";
    case QueueKind::Transfer: return "transfer";
    case QueueKind::Host: return "host";
    }
    return "?";
}

std::string mebibytes(VkDeviceSize bytes) { return fmt::format("{:.2f} MiB", double(bytes) / (1024.0 * 1024.0)); }

std::string describe(const CompiledResource& res)
{
    std::string text = res.isImage ? fmt::format("image {}x{}{} {}", res.width, res.height,
                                                 res.layers > 1 ? fmt::format(" x {} layers", res.layers) : "",
                                                 vk::to_string(vk::Format(res.format)))
                                   : std::string("buffer");
    text += fmt::format(", {}", mebibytes(res.sizeBytes));
    if (res.hostVisible) text += ", host-visible";
    if (res.imported) text += ", imported";
    else if (res.memorySlot >= 0) text += fmt::format(", slot {}", res.memorySlot);
    if (res.persistent) text += ", persistent";
    if (res.markedOutput) text += ", output";
    if (res.readBack) text += ", read back";
    return text;
}

std::string stages(VkPipelineStageFlags2 flags)
{
    return flags == 0 ? "{ None }" : vk::to_string(vk::PipelineStageFlags2(flags));
}

std::string accesses(VkAccessFlags2 flags) { return flags == 0 ? "{ None }" : vk::to_string(vk::AccessFlags2(flags)); }

std::string layout(VkImageLayout value) { return vk::to_string(vk::ImageLayout(value)); }

std::string describe(const Barrier& b, const std::vector<CompiledResource>& resources)
{
    std::string text = fmt::format("      barrier '{}'", resources[b.resource].name);
    if (b.isImage) text += fmt::format(" {} -> {}", layout(b.oldLayout), layout(b.newLayout));
    return text + fmt::format(": {} {} -> {} {}\n", stages(b.srcStage), accesses(b.srcAccess), stages(b.dstStage),
                              accesses(b.dstAccess));
}

std::string dotEscape(const std::string& text)
{
    std::string out;
    for (char c : text) {
        if (c == '"' || c == '\\') out += '\\';
        out += c;
    }
    return out;
}

} // namespace

std::string CompiledGraph::toText() const
{
    std::string text = fmt::format("render graph: {} passes, {} culled; transient memory {} aliased into {} "
                                   "({} slots)\n",
                                   passes.size(), culled.size(), mebibytes(transientBytesUnaliased),
                                   mebibytes(transientBytesAliased), memorySlots.size());
    text += "passes in order:\n";
    for (size_t i = 0; i < passes.size(); ++i) {
        text += fmt::format("  {} {} ({}){}\n", i, passes[i].name, queueName(passes[i].queue),
                            passes[i].keptWhile.empty() ? "" : fmt::format(", kept while {} unchanged",
                                                                           fmt::join(passes[i].keptWhile, ", ")));
        for (const Barrier& b : passes[i].barriersBefore) text += describe(b, resources);
    }
    if (!barriersAfter.empty()) {
        text += "after the last pass:\n";
        for (const Barrier& b : barriersAfter) text += describe(b, resources);
    }
    text += "culled:\n";
    for (const CulledPass& pass : culled) text += fmt::format("  {}: {}\n", pass.name, pass.reason);
    text += "resources:\n";
    for (const CompiledResource& res : resources) {
        text += fmt::format("  {}: {}", res.name, describe(res));
        if (res.firstUse >= 0) text += fmt::format(", passes {}..{}\n", res.firstUse, res.lastUse);
        else text += ", unused\n";
    }
    return text;
}

std::string CompiledGraph::toDot() const
{
    std::string dot = "digraph render_graph {\n  rankdir=LR;\n  node [fontname=\"sans\"];\n";
    for (size_t i = 0; i < passes.size(); ++i)
        dot += fmt::format("  \"pass:{0}\" [shape=box, label=\"{1}: {0}\\n{2}\"];\n", dotEscape(passes[i].name), i,
                           queueName(passes[i].queue));
    for (const CulledPass& pass : culled)
        dot += fmt::format("  \"pass:{0}\" [shape=box, style=dashed, color=gray, label=\"{0}\\nculled: {1}\"];\n",
                           dotEscape(pass.name), dotEscape(pass.reason));
    for (const CompiledResource& res : resources)
        dot += fmt::format("  \"res:{0}\" [shape=ellipse, label=\"{0}\\n{1}\"];\n", dotEscape(res.name),
                           dotEscape(describe(res)));
    for (size_t i = 0; i + 1 < passes.size(); ++i)
        dot += fmt::format("  \"pass:{}\" -> \"pass:{}\" [style=invis];\n", dotEscape(passes[i].name),
                           dotEscape(passes[i + 1].name));
    for (const CompiledPass& pass : passes)
        for (const ResourceUse& use : pass.uses) {
            const std::string res = dotEscape(resources[use.resource].name);
            const std::string name = dotEscape(pass.name);
            if (use.writes) dot += fmt::format("  \"pass:{}\" -> \"res:{}\";\n", name, res);
            if (use.reads) dot += fmt::format("  \"res:{}\" -> \"pass:{}\";\n", res, name);
        }
    dot += "}\n";
    return dot;
}

} // namespace penumbra::graph
