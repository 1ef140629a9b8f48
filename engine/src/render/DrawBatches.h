#pragma once
// How render::SceneGpu turns "draw these instances" into few draw calls. The instance
// table is ordered by (base-colour texture, mesh, instance): a row is an instance's
// *slot*, and the instances of a mesh sit in consecutive slots. A draw becomes one
// indirect command per run of consecutive drawn slots of one mesh (instanceCount: the
// run's length, firstInstance: its first slot, so that shaders still read
// instances[gl_InstanceIndex]), and the commands between two texture changes are one
// group: one vkCmdDrawIndexedIndirect with drawCount > 1 (lavapipe has no descriptor
// indexing, so a texture change still needs its own descriptor push and call).
//
// Drawn without a mask every mesh is one command; with an instance mask (the visibility
// service's casters and receivers) a mesh splits into as many commands as its drawn
// instances form runs; never more commands than instances, and exactly the instances the
// filter and mask select are drawn (DrawCounts are those of one draw per instance).
//
// Order: a depth-only pass's result does not depend on draw order (the depth test keeps
// the nearest fragment whichever comes first), nor does an occlusion query's "any sample
// passed". Colour passes see a different order than instance order only where two
// different meshes write the same depth in one pixel.
#include "penumbra/render/SceneGpu.h"

#include <vulkan/vulkan.h>

#include <cstdint>
#include <span>
#include <vector>

namespace penumbra::render {

// One mesh's place in the scene's index and vertex buffers and what groups its draws.
struct MeshRange {
    uint32_t indexCount = 0;  // 0: nothing to draw (its instances get no slot)
    uint32_t firstIndex = 0;
    int32_t vertexOffset = 0;
    uint32_t texture = 0;  // the base-colour texture a pass binds for it
    bool alphaMasked = false;
    // Light passes through it in places: alpha-masked holes, or a translucent (BLEND)
    // surface. Occlusion culling never lets such an instance hide another.
    bool seeThrough = false;
};

// The draws of one SceneGpu::draw / drawInstances, ready to record.
struct DrawBatch {
    // Commands between two texture changes: one indirect multi-draw.
    struct Group {
        uint32_t texture = 0;
        uint32_t firstCommand = 0;
        uint32_t commandCount = 0;
    };
    std::vector<VkDrawIndexedIndirectCommand> commands;
    std::vector<Group> groups;
    DrawCounts counts;  // instances and triangles; drawCalls is the recorder's
    std::vector<uint32_t> slots;  // drawInstances' scratch: the requested slots, sorted
};

class DrawBatches {
public:
    static constexpr uint32_t kNoSlot = UINT32_MAX;

    // `instanceMesh`: each instance's mesh; `meshes`: each mesh's range. `perInstance`:
    // one command per instance (instanceCount 1), the reference the batched draws are
    // checked against and measured with.
    DrawBatches(std::span<const uint32_t> instanceMesh, std::span<const MeshRange> meshes, bool perInstance);

    // The instance in each slot: the rows of the instance table, in order.
    std::span<const uint32_t> slotInstances() const { return slotInstance_; }
    // An instance's slot; kNoSlot when its mesh has no triangles. Throws for an index
    // out of range.
    uint32_t slotOf(uint32_t instance) const;
    bool isAlphaMasked(uint32_t instance) const;
    bool hasAlphaMasked() const;
    size_t instanceCount() const { return instanceSlot_.size(); }

    // The slots that pass `filter` and, when given, `instanceMask` (one entry per
    // instance, non-zero: drawn), in slot order; `byTexture`: a new group at every
    // texture change, else one group for everything.
    void build(DrawFilter filter, const std::vector<uint8_t>* instanceMask, bool byTexture, DrawBatch& out) const;
    // The given instances (any order, repeats drawn again) whose see-through flag
    // (MeshRange::seeThrough) is `seeThrough`, as one group.
    void buildInstances(std::span<const uint32_t> instances, bool seeThrough, DrawBatch& out) const;

private:
    // The slots of one mesh: [firstSlot, firstSlot + count).
    struct Segment {
        uint32_t firstSlot;
        uint32_t count;
        uint32_t mesh;
    };
    void emitRun(uint32_t firstSlot, uint32_t count, const MeshRange& mesh, bool byTexture, DrawBatch& out) const;

    std::vector<MeshRange> meshes_;
    std::vector<Segment> segments_;      // in slot order
    std::vector<uint32_t> slotInstance_;  // slot -> instance
    std::vector<uint32_t> slotSegment_;   // slot -> index into segments_
    std::vector<uint32_t> instanceSlot_;  // instance -> slot (kNoSlot: no triangles)
    std::vector<uint8_t> instanceMasked_;      // instance -> alpha-masked
    std::vector<uint8_t> instanceSeeThrough_;  // instance -> MeshRange::seeThrough
    bool perInstance_;
};

} // namespace penumbra::render
