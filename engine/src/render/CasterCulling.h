#pragma once
// What render::Casters asks before it draws: which casters a light view needs. The
// engine's visibility service (engine/src/visibility/) implements it. The interface lives
// here, below the service, so that render::Casters calls up into the service without
// render depending on it (the layering: visibility -> render), and it is private to the
// engine: Casters.h only names it, so plugins never see the service.
#include "penumbra/render/Casters.h"
#include "penumbra/render/SceneGpu.h"
#include "penumbra/scene/Scene.h"

#include <cstdint>
#include <optional>
#include <vector>

namespace penumbra::render {

class CasterCulling {
public:
    // The casters `view` must draw this frame, one entry per instance (non-zero: drawn),
    // or null for all.
    virtual const std::vector<uint8_t>* casters(const CasterView& view) = 0;
    // The texels of `view` (view texels) that this frame's receivers can read: the bounds
    // of its dilated receiver mask (receiver-mask culling); nullopt: any texel.
    virtual std::optional<VkRect2D> readArea(const CasterView& view) = 0;
    // What a Casters::draw drew, and the texels a caster pass rendered (its render area),
    // for the frame's figures.
    virtual void countDraw(const DrawCounts& counts) = 0;
    virtual void countRenderedTexels(uint64_t texels) = 0;
    // The box of what the camera sees this frame when shadow-map focusing is on, else null.
    virtual const scene::Aabb* focus() const = 0;

protected:
    ~CasterCulling() = default;
};

} // namespace penumbra::render
