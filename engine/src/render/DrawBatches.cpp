#include "render/DrawBatches.h"

#include "penumbra/core/Error.h"

#include <fmt/format.h>

#include <algorithm>

namespace penumbra::render {

DrawBatches::DrawBatches(std::span<const uint32_t> instanceMesh, std::span<const MeshRange> meshes, bool perInstance)
    : meshes_(meshes.begin(), meshes.end()), perInstance_(perInstance)
{
    for (uint32_t i = 0; i < instanceMesh.size(); ++i) {
        if (instanceMesh[i] >= meshes_.size())
            throw Error(fmt::format("instance {}: mesh {} does not exist ({} meshes)", i, instanceMesh[i],
                                    meshes_.size()));
        if (meshes_[instanceMesh[i]].indexCount > 0) slotInstance_.push_back(i);
    }
    // Texture first (a pass pushes each texture's descriptor once), then mesh (its
    // instances become one command), then instance order.
    std::stable_sort(slotInstance_.begin(), slotInstance_.end(), [&](uint32_t a, uint32_t b) {
        const MeshRange &ma = meshes_[instanceMesh[a]], &mb = meshes_[instanceMesh[b]];
        if (ma.texture != mb.texture) return ma.texture < mb.texture;
        return instanceMesh[a] < instanceMesh[b];
    });
    instanceSlot_.assign(instanceMesh.size(), kNoSlot);
    instanceMasked_.assign(instanceMesh.size(), 0);
    instanceSeeThrough_.assign(instanceMesh.size(), 0);
    slotSegment_.resize(slotInstance_.size());
    for (uint32_t slot = 0; slot < slotInstance_.size(); ++slot) {
        const uint32_t instance = slotInstance_[slot];
        const uint32_t mesh = instanceMesh[instance];
        if (segments_.empty() || segments_.back().mesh != mesh) segments_.push_back({slot, 0, mesh});
        ++segments_.back().count;
        slotSegment_[slot] = uint32_t(segments_.size() - 1);
        instanceSlot_[instance] = slot;
        instanceMasked_[instance] = meshes_[mesh].alphaMasked ? 1 : 0;
        instanceSeeThrough_[instance] = meshes_[mesh].seeThrough ? 1 : 0;
    }
}

uint32_t DrawBatches::slotOf(uint32_t instance) const
{
    if (instance >= instanceSlot_.size())
        throw Error(fmt::format("SceneGpu: instance {} does not exist ({} instances)", instance,
                                instanceSlot_.size()));
    return instanceSlot_[instance];
}

bool DrawBatches::isAlphaMasked(uint32_t instance) const
{
    slotOf(instance);  // range check
    return instanceMasked_[instance] != 0;
}

bool DrawBatches::hasAlphaMasked() const
{
    return std::any_of(segments_.begin(), segments_.end(), [&](const Segment& s) { return meshes_[s.mesh].alphaMasked; });
}

void DrawBatches::emitRun(uint32_t firstSlot, uint32_t count, const MeshRange& mesh, bool byTexture,
                          DrawBatch& out) const
{
    if (out.groups.empty() || (byTexture && out.groups.back().texture != mesh.texture))
        out.groups.push_back({mesh.texture, uint32_t(out.commands.size()), 0});
    const uint32_t perCommand = perInstance_ ? 1u : count;
    for (uint32_t done = 0; done < count; done += perCommand) {
        out.commands.push_back({mesh.indexCount, perCommand, mesh.firstIndex, mesh.vertexOffset, firstSlot + done});
        ++out.groups.back().commandCount;
    }
    out.counts.instances += count;
    out.counts.triangles += uint64_t(count) * (mesh.indexCount / 3);
}

void DrawBatches::build(DrawFilter filter, const std::vector<uint8_t>* instanceMask, bool byTexture,
                        DrawBatch& out) const
{
    if (instanceMask && instanceMask->size() != instanceSlot_.size()) {
        throw Error(fmt::format("SceneGpu::draw: an instance mask of {} entries for {} instances",
                                instanceMask->size(), instanceSlot_.size()));
    }
    out.commands.clear();
    out.groups.clear();
    out.counts = {};
    for (const Segment& segment : segments_) {
        const MeshRange& mesh = meshes_[segment.mesh];
        if ((filter == DrawFilter::Solid && mesh.alphaMasked) || (filter == DrawFilter::AlphaMasked && !mesh.alphaMasked) ||
            (filter == DrawFilter::Opaque && mesh.seeThrough))
            continue;
        if (!instanceMask) {
            emitRun(segment.firstSlot, segment.count, mesh, byTexture, out);
            continue;
        }
        uint32_t runStart = 0, runLength = 0;
        for (uint32_t slot = segment.firstSlot; slot < segment.firstSlot + segment.count; ++slot) {
            if ((*instanceMask)[slotInstance_[slot]]) {
                if (runLength == 0) runStart = slot;
                ++runLength;
            } else if (runLength > 0) {
                emitRun(runStart, runLength, mesh, byTexture, out);
                runLength = 0;
            }
        }
        if (runLength > 0) emitRun(runStart, runLength, mesh, byTexture, out);
    }
}

void DrawBatches::buildInstances(std::span<const uint32_t> instances, bool seeThrough, DrawBatch& out) const
{
    out.commands.clear();
    out.groups.clear();
    out.counts = {};
    out.slots.clear();
    for (const uint32_t instance : instances) {
        const uint32_t slot = slotOf(instance);
        if (slot != kNoSlot && (instanceSeeThrough_[instance] != 0) == seeThrough) out.slots.push_back(slot);
    }
    std::sort(out.slots.begin(), out.slots.end());
    // A run: consecutive slots of one segment (one mesh); a repeated slot starts a new one.
    for (size_t i = 0; i < out.slots.size();) {
        size_t end = i + 1;
        while (end < out.slots.size() && out.slots[end] == out.slots[end - 1] + 1 &&
               slotSegment_[out.slots[end]] == slotSegment_[out.slots[i]])
            ++end;
        emitRun(out.slots[i], uint32_t(end - i), meshes_[segments_[slotSegment_[out.slots[i]]].mesh], false, out);
        i = end;
    }
}

} // namespace penumbra::render
