#include "RandomGraph.h"

#include <fmt/format.h>

#include <algorithm>
#include <random>

namespace penumbra::graphtest {

using namespace penumbra::graph;

void buildRandomGraph(RandomGraph& out, uint32_t passCount, uint32_t seed, const RandomGraphOptions& options)
{
    const bool transfer = options.smallTransferBuffers;
    std::mt19937 rng(seed);
    auto chance = [&](int percent) { return std::uniform_int_distribution<int>(0, 99)(rng) < percent; };
    auto pick = [&](size_t count) { return std::uniform_int_distribution<size_t>(0, count - 1)(rng); };

    struct Produced {
        std::string name;
        bool isImage;
        bool depth;
    };
    std::vector<Produced> produced;
    for (int i = 0; i < 3; ++i) {
        const std::string name = fmt::format("imported{}", i);
        if (transfer) {
            out.graph.declareBuffer({name, 256, true});
            out.bufferBytes[name] = 256;
        } else {
            out.graph.declareImage({name, 1920, 1080, VK_FORMAT_R16G16B16A16_SFLOAT, true,
                                    VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL});
        }
        out.imported.push_back(name);
    }

    const uint32_t edges[] = {256, 512, 1024, 2048};
    const VkFormat colorFormats[] = {VK_FORMAT_R8G8B8A8_UNORM, VK_FORMAT_R16_SFLOAT, VK_FORMAT_R32_SFLOAT,
                                     VK_FORMAT_R16G16B16A16_SFLOAT};
    for (uint32_t p = 0; p < passCount; ++p) {
        const std::string passName = fmt::format("pass{}", p);
        const bool graphics = chance(50);
        const QueueKind queue = transfer ? QueueKind::Transfer : graphics ? QueueKind::Graphics : QueueKind::Compute;
        const bool sideEffect = chance(5);
        PassBuilder pass = out.graph.addPass(passName, queue, sideEffect);
        out.passes.push_back(pass);
        out.passNames.push_back(passName);
        out.sideEffect.push_back(sideEffect);
        out.reads.emplace_back();
        out.writes.emplace_back();

        const int readCount = std::uniform_int_distribution<int>(0, 3)(rng);
        for (int k = 0; k < readCount; ++k) {
            if (chance(5)) {
                const std::string& name = out.imported[pick(out.imported.size())];
                if (std::find(out.reads.back().begin(), out.reads.back().end(), name) != out.reads.back().end())
                    continue;
                pass.read(name, transfer ? Usage::TransferSrc : Usage::Sampled);
                out.reads.back().push_back(name);
                continue;
            }
            if (produced.empty()) break;
            // Mostly one of the last few results; sometimes anything (a long lifetime).
            const size_t back = chance(80) ? std::min(pick(8), produced.size() - 1) : pick(produced.size());
            const Produced& source = produced[produced.size() - 1 - back];
            if (std::find(out.reads.back().begin(), out.reads.back().end(), source.name) != out.reads.back().end())
                continue;
            pass.read(source.name, transfer ? Usage::TransferSrc : source.isImage ? Usage::Sampled : Usage::Storage);
            out.reads.back().push_back(source.name);
        }

        const int writeCount = chance(70) ? 1 : 2;
        for (int k = 0; k < writeCount; ++k) {
            const std::string name = fmt::format("r{}_{}", p, k);
            const bool isImage = !transfer && chance(75);
            bool depth = false;
            if (isImage) {
                depth = queue == QueueKind::Graphics && chance(20);
                const uint32_t edge = edges[pick(4)];
                out.graph.declareImage(
                    {name, edge, edge, depth ? VK_FORMAT_D32_SFLOAT : colorFormats[pick(4)], false, {}});
                const Usage usage = queue == QueueKind::Compute ? Usage::Storage
                                    : depth                     ? Usage::DepthAttachment
                                                                : Usage::ColorAttachment;
                pass.write(name, usage);
            } else {
                const VkDeviceSize bytes = transfer ? VkDeviceSize(64) << pick(7) : VkDeviceSize(1024) << pick(12);
                out.graph.declareBuffer({name, bytes, false});
                out.bufferBytes[name] = bytes;
                pass.write(name, transfer ? Usage::TransferDst : Usage::Storage);
            }
            out.writes.back().push_back(name);
            produced.push_back({name, isImage, depth});
            if (chance(5) || p + 1 == passCount) {
                out.graph.markOutput(name);
                out.marked.push_back(name);
            }
        }
    }
}

} // namespace penumbra::graphtest
