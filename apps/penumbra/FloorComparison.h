#pragma once
// The frame's passes as multiples of the floor's (frame/FloorRenderer.h): what
// `render --timings` prints and `bench` records per variant. The rule (kFloorRule):
//   - a camera pass (one that writes an image of the frame's size: G-buffer, visibility
//     images, shading) is set against the floor's forward draw;
//   - any other pass (a light pass: shadow maps, light-space filters) against the floor's
//     shadow-map draw of its light ("light<i>." names it), or of every light when its name
//     names none;
//   - the frame's sum of passes against the floor frame: the shadowed one (shadow maps +
//     forward with one compare per light) when some light is shadowed, else the
//     unshadowed one (forward without compares).
// The forward draw is the one of that floor frame. A host pass counts its CPU time.
#include "TimingSummary.h"

#include "penumbra/frame/FloorRenderer.h"
#include "penumbra/frame/FrameRenderer.h"
#include "penumbra/graph/RenderGraph.h"

#include <cstddef>
#include <set>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra::app {

// The rule above, in one line, for the headers of the printed and written reports.
extern const std::string_view kFloorRule;

enum class FloorDraw { Forward, ShadowMap };
const char* floorDrawName(FloorDraw draw);  // "forward", "shadow map"

// The floor's medians over its measured frames.
struct FloorSummary {
    TimingSummary passes;            // every floor pass
    double shadowedFrameMs = 0.0;    // per frame the sum of the floor.shadowed.* passes, then the median
    double unshadowedFrameMs = 0.0;  // likewise floor.unshadowed.*
    double shadowedForwardMs = 0.0;
    double unshadowedForwardMs = 0.0;
    std::vector<double> shadowMapMs;  // per light
    double allShadowMapsMs = 0.0;     // per frame the sum over the lights, then the median
};
FloorSummary summarizeFloor(const std::vector<frame::FrameTimings>& frames, size_t lights);

struct PassAgainstFloor {
    std::string name;
    FloorDraw draw = FloorDraw::Forward;
    double floorMs = 0.0;
    double multiple = 0.0;  // the pass's work / floorMs; NaN when the floor took no time
};

struct FloorComparison {
    FloorSummary floor;
    bool shadowed = true;      // compared with the shadowed floor frame
    double floorFrameMs = 0.0;
    double frameMultiple = 0.0;  // the frame's sum of passes (work) / floorFrameMs; NaN when 0
    std::vector<PassAgainstFloor> passes;  // the frame's, in its order
};

// The passes of `graph` that write an image of width x height: the camera passes.
std::set<std::string, std::less<>> cameraPasses(const graph::CompiledGraph& graph, uint32_t width, uint32_t height);

// Whether some light of `renderer` is shadowed (has a technique other than "none").
bool anyLightShadowed(const frame::FrameRenderer& renderer);

FloorComparison compareWithFloor(const TimingSummary& frame, const std::set<std::string, std::less<>>& cameraPasses,
                                 const FloorSummary& floor, bool shadowed);

// The figures `render --timings` prints after the frame's table.
void printFloor(const FloorComparison& comparison);

} // namespace penumbra::app
