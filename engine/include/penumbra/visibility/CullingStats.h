#pragma once
// The visibility service's figures for one frame, the only part of engine/src/visibility/
// that callers see (frame::FrameTimings carries them; `render --stats`, `bench` and
// `graph` print them). The service itself stays private to the engine: techniques see
// only render::Casters (DESIGN.md "visibility"). The figures live under the service's
// own name, not under frame/, because the service is what defines and fills them.
#include <cstdint>

namespace penumbra::visibility {

// Per frame, summed over the camera and every light view.
struct CullingStats {
    uint64_t nodesVisited = 0;      // BVH nodes the traversals looked at
    uint64_t queriesIssued = 0;     // occlusion queries (boxes, multi-queries, leaf draws)
    uint64_t maskRejected = 0;      // nodes culled without a query: their projection meets no mask texel
    uint64_t floorRejected = 0;     // nodes culled without a query: behind every receiver depth they meet
    uint64_t queryRounds = 0;       // submissions waited for
    uint64_t receivers = 0;         // instances the camera sees (the G-buffer draws them)
    uint64_t cameraFellBack = 0;    // 1: the camera took its frustum (culling kept most last time)
    uint64_t views = 0;             // light views culled
    uint64_t viewsFellBack = 0;     // of which culled to their frustum: culling kept most last time
    uint64_t castersDrawn = 0;      // instance draws through Casters::draw
    uint64_t trianglesDrawn = 0;    // their triangles
    uint64_t mapTexelsRendered = 0; // texels the caster passes cleared and drew into (render areas)
    uint64_t masksOnHost = 0;       // receiver masks scattered by the host, not the device
    double cameraMs = 0.0;          // step 1: camera culling (wall clock, GPU work waited for)
    double maskMs = 0.0;            // step 2: receiver masks
    double casterCullMs = 0.0;      // step 3: caster culling (queries, or frustum tests)
};

} // namespace penumbra::visibility
