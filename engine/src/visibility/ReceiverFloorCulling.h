#pragma once
// Caster culling on the CPU alone, for a light view whose technique compares every lookup
// with the receiver's own depth (ReceiverMask::hasReceiverDepth): an instance is kept
// unless its box projects onto no texel of the receiver mask, or lies behind the receiver
// floor (the least receiver depth, ReceiverMask::behindReceivers) at every texel it
// projects onto. A culled instance is behind every receiver that reads any texel it could
// cover, so whether it is drawn changes no comparison: the image is the one with every
// caster drawn.
//
// Why not the occlusion queries (OcclusionTraversal.h) for such views: on lavapipe a
// query's cost is the fill of its proxy and of the leaves drawn before it, at the map's
// resolution, behind a fragment shader that tests the mask and the receiver depths. On
// city street views they cost 60 to 850 ms a frame to save a depth pass of 10 to 140 ms
// (docs/culling.md "Where the time went"). The CPU test keeps the instances a shadow ray
// from a visible receiver could pass through, behind or in front of other casters alike;
// the queries also dropped those hidden behind other casters, which the depth pass
// draws for far less than the queries cost.
#include "penumbra/render/Casters.h"
#include "penumbra/scene/Bvh.h"
#include "penumbra/scene/Scene.h"
#include "penumbra/visibility/CullingStats.h"
#include "visibility/ReceiverMask.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <vector>

namespace penumbra::visibility {

// Culls the instances of `scene` (over which `bvh` is built) for the light view `viewProj`,
// drawn by its technique with `bias`, whose receiver mask, with receiver depths, is `mask`:
// `visible` gets one entry per instance (non-zero: kept), `stats` the nodes visited and
// culled.
void cullBehindReceivers(const scene::InstanceBvh& bvh, const scene::Scene& scene, const glm::mat4& viewProj,
                         const render::ShadowDepthBias& bias, const ReceiverMask& mask, std::vector<uint8_t>& visible,
                         CullingStats& stats);

} // namespace penumbra::visibility
