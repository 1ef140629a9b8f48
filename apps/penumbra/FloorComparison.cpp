#include "FloorComparison.h"

#include <fmt/format.h>

#include <cctype>
#include <limits>
#include <optional>

namespace penumbra::app {

const std::string_view kFloorRule =
    "x floor: a camera pass (writes an image of the frame's size) over the floor's forward draw, any other pass over "
    "the floor's shadow-map draw of its light (light<i>.; every light's when it names none), the sum of passes over "
    "the floor frame (shadowed: maps + forward with one compare per light; unshadowed when no light is shadowed)";

const char* floorDrawName(FloorDraw draw) { return draw == FloorDraw::Forward ? "forward" : "shadow map"; }

namespace {

// a / b, NaN when b took no time (a pass the floor lacks cannot be a multiple of it).
double ratio(double a, double b) { return b > 0.0 ? a / b : std::numeric_limits<double>::quiet_NaN(); }

// The light a pass belongs to by its name ("light3.hard.shadow_map": 3), or none.
std::optional<size_t> lightOfPass(std::string_view name)
{
    constexpr std::string_view kLight = "light";
    if (name.substr(0, kLight.size()) != kLight) return std::nullopt;
    size_t i = kLight.size(), light = 0;
    if (i >= name.size() || !std::isdigit(static_cast<unsigned char>(name[i]))) return std::nullopt;
    while (i < name.size() && std::isdigit(static_cast<unsigned char>(name[i]))) light = light * 10 + size_t(name[i++] - '0');
    if (i < name.size() && name[i] != '.') return std::nullopt;
    return light;
}

double passMs(const TimingSummary& summary, std::string_view name)
{
    for (const PassTimes& p : summary.passes)
        if (p.name == name) return p.host ? p.cpuMs : p.gpuMs;
    return 0.0;
}

} // namespace

FloorSummary summarizeFloor(const std::vector<frame::FrameTimings>& frames, size_t lights)
{
    FloorSummary s;
    s.passes = summarizeTimings(frames);
    s.shadowedFrameMs = summarizeTimings(frames, frame::kFloorShadowedPrefix).gpuMs;
    s.unshadowedFrameMs = summarizeTimings(frames, frame::kFloorUnshadowedPrefix).gpuMs;
    s.shadowedForwardMs = passMs(s.passes, frame::kFloorShadowedForward);
    s.unshadowedForwardMs = passMs(s.passes, frame::kFloorUnshadowedForward);
    for (size_t l = 0; l < lights; ++l) s.shadowMapMs.push_back(passMs(s.passes, frame::floorShadowMapPass(l)));
    s.allShadowMapsMs = summarizeTimings(frames, fmt::format("{}light", frame::kFloorShadowedPrefix)).gpuMs;
    return s;
}

std::set<std::string, std::less<>> cameraPasses(const graph::CompiledGraph& graph, uint32_t width, uint32_t height)
{
    std::set<std::string, std::less<>> names;
    for (const graph::CompiledPass& pass : graph.passes) {
        for (const graph::ResourceUse& use : pass.uses) {
            const graph::CompiledResource& r = graph.resources.at(use.resource);
            if (use.writes && r.isImage && r.width == width && r.height == height) names.insert(pass.name);
        }
    }
    return names;
}

bool anyLightShadowed(const frame::FrameRenderer& renderer)
{
    for (size_t l = 0; l < renderer.lightCount(); ++l) {
        const std::string& technique = renderer.techniqueName(l);
        if (!technique.empty() && technique != "none") return true;
    }
    return false;
}

FloorComparison compareWithFloor(const TimingSummary& frame, const std::set<std::string, std::less<>>& cameraPasses,
                                 const FloorSummary& floor, bool shadowed)
{
    FloorComparison c;
    c.floor = floor;
    c.shadowed = shadowed;
    c.floorFrameMs = shadowed ? floor.shadowedFrameMs : floor.unshadowedFrameMs;
    c.frameMultiple = ratio(frame.workMs, c.floorFrameMs);
    const double forwardMs = shadowed ? floor.shadowedForwardMs : floor.unshadowedForwardMs;
    for (const PassTimes& p : frame.passes) {
        PassAgainstFloor a;
        a.name = p.name;
        if (cameraPasses.count(p.name)) {
            a.draw = FloorDraw::Forward;
            a.floorMs = forwardMs;
        } else {
            a.draw = FloorDraw::ShadowMap;
            const std::optional<size_t> light = lightOfPass(p.name);
            a.floorMs = light && *light < floor.shadowMapMs.size() ? floor.shadowMapMs[*light] : floor.allShadowMapsMs;
        }
        a.multiple = ratio(p.host ? p.cpuMs : p.gpuMs, a.floorMs);
        c.passes.push_back(std::move(a));
    }
    return c;
}

void printFloor(const FloorComparison& c)
{
    fmt::print("floor (the scene drawn once forward, frame/FloorRenderer.h): median of {} frame(s)\n", c.floor.passes.frames);
    fmt::print("  {:<34} {:>10}\n", "floor pass", "GPU ms");
    for (const PassTimes& p : c.floor.passes.passes) fmt::print("  {:<34} {:>10.3f}\n", p.name, p.gpuMs);
    fmt::print("  {:<34} {:>10.3f}\n", "shadowed floor frame", c.floor.shadowedFrameMs);
    fmt::print("  {:<34} {:>10.3f}\n", "unshadowed floor frame", c.floor.unshadowedFrameMs);
}

} // namespace penumbra::app
