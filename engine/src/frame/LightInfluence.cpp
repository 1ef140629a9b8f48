#include "penumbra/frame/LightInfluence.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace penumbra::frame {
namespace {

constexpr double kPi = 3.14159265358979323846;
// The shading's floor on a squared distance (shaders/common/lambert.glsl).
constexpr double kMinDistance2 = 1e-30;

// The light's radiant intensity (or irradiance) in its brightest channel, times the
// exposure, over pi: what a white surface facing it at distance 1 reflects.
double radianceScale(const scene::Light& light, double exposure)
{
    const double brightest = std::max({double(light.color.r), double(light.color.g), double(light.color.b)});
    return exposure * double(light.intensity) * brightest / kPi;
}

double distance2(const glm::dvec3& p, const scene::Aabb& box)
{
    const glm::dvec3 lo(box.min), hi(box.max);
    const glm::dvec3 nearest = glm::clamp(p, lo, hi);
    const glm::dvec3 d = p - nearest;
    return glm::dot(d, d);
}

// Whether the cone (apex, unit axis, half-angle) meets the box. The sphere around the box
// decides when it misses the cone or its centre lies inside it; otherwise the box is
// halved along its longest side, kConeSplits times at most, since a flat floor's sphere
// holds far more than the floor (a light above it pointing up would never be culled).
// Conservative: undecided at the last split counts as meeting.
constexpr int kConeSplits = 12;

bool coneMeetsBox(const glm::dvec3& apex, const glm::dvec3& axis, double halfAngle, const glm::dvec3& lo,
                  const glm::dvec3& hi, int splits = 0)
{
    const glm::dvec3 centre = 0.5 * (lo + hi);
    const double radius = 0.5 * glm::length(hi - lo);
    const glm::dvec3 v = centre - apex;
    const double dist = glm::length(v);
    if (glm::all(glm::lessThanEqual(lo, apex)) && glm::all(glm::lessThanEqual(apex, hi))) return true;
    if (std::isnan(dist)) return true;  // keep the light
    if (dist > radius) {  // else the apex lies in the sphere: only a split can tell
        const double angleToCentre = std::acos(std::clamp(glm::dot(v, axis) / dist, -1.0, 1.0));
        if (angleToCentre <= halfAngle) return true;  // the centre lies in the cone
        const double sphereAngle = std::asin(std::clamp(radius / dist, 0.0, 1.0));
        if (angleToCentre > halfAngle + sphereAngle) return false;
    }
    if (splits == kConeSplits) return true;
    const glm::dvec3 size = hi - lo;
    const int side = size.x >= size.y && size.x >= size.z ? 0 : (size.y >= size.z ? 1 : 2);
    glm::dvec3 midHi = hi, midLo = lo;
    midHi[side] = midLo[side] = centre[side];
    return coneMeetsBox(apex, axis, halfAngle, lo, midHi, splits + 1) ||
           coneMeetsBox(apex, axis, halfAngle, midLo, hi, splits + 1);
}

// The part of the screen (0..1) the box covers: its corners' NDC bounds; a box reaching
// behind the camera counts as the whole screen.
double screenCoverage(const glm::mat4& viewProj, const scene::Aabb& box)
{
    glm::dvec2 lo(std::numeric_limits<double>::max()), hi(-std::numeric_limits<double>::max());
    for (int c = 0; c < 8; ++c) {
        const glm::dvec4 clip = glm::dmat4(viewProj) * glm::dvec4(glm::dvec3(box.corner(c)), 1.0);
        if (!(clip.w > 1e-12)) return 1.0;
        const glm::dvec2 ndc = glm::dvec2(clip) / clip.w;
        lo = glm::min(lo, ndc);
        hi = glm::max(hi, ndc);
    }
    lo = glm::clamp(lo, glm::dvec2(-1.0), glm::dvec2(1.0));
    hi = glm::clamp(hi, glm::dvec2(-1.0), glm::dvec2(1.0));
    const glm::dvec2 size = glm::max(hi - lo, glm::dvec2(0.0));
    return size.x * size.y / 4.0;
}

scene::Aabb grown(const scene::Aabb& box, const glm::vec3& camera)
{
    const double size = double(box.radius());
    const double distance = glm::length(glm::dvec3(box.center()) - glm::dvec3(camera));
    const float slack = float(kReceiverSlack * (distance + size));
    scene::Aabb out = box;
    out.min -= glm::vec3(slack);
    out.max += glm::vec3(slack);
    return out;
}

} // namespace

const char* lightFateName(LightFate fate)
{
    switch (fate) {
    case LightFate::Shadowed: return "shadowed";
    case LightFate::Unshadowed: return "unshadowed";
    case LightFate::Culled: return "culled";
    }
    return "unknown";
}

double lightRange(const scene::Light& light, double exposure)
{
    if (light.type == scene::LightType::Directional) return std::numeric_limits<double>::infinity();
    const double scale = radianceScale(light, exposure);
    if (std::isnan(scale)) return std::numeric_limits<double>::infinity();
    return scale > 0.0 ? std::sqrt(scale / kLightCutoffRadiance) : 0.0;
}

double lightRadianceBound(const scene::Light& light, const scene::Aabb& box, double exposure)
{
    const double scale = radianceScale(light, exposure);
    if (std::isnan(scale)) return std::numeric_limits<double>::infinity();  // never culled on a NaN
    if (!(scale > 0.0) || box.empty()) return 0.0;
    if (light.type == scene::LightType::Directional) return scale;
    const glm::dvec3 position(light.position);
    const glm::dvec3 axis = glm::normalize(glm::dvec3(light.direction));
    if (light.type == scene::LightType::Spot) {
        const double outer = glm::radians(std::clamp(double(light.outerConeDeg), 0.0, 180.0));
        if (!coneMeetsBox(position, axis, outer + kConeSlackRad, glm::dvec3(box.min), glm::dvec3(box.max))) return 0.0;
    }
    if (light.type == scene::LightType::Rect || light.type == scene::LightType::Disk) {
        double ahead = -std::numeric_limits<double>::max();
        for (int c = 0; c < 8; ++c) ahead = std::max(ahead, glm::dot(axis, glm::dvec3(box.corner(c)) - position));
        if (!(ahead > 0.0) && !std::isnan(ahead)) return 0.0;
    }
    return scale / std::max(distance2(position, box), kMinDistance2);
}

std::vector<LightDecision> decideLights(const LightCullingInput& input)
{
    std::vector<scene::Aabb> boxes;
    std::vector<double> coverage;
    boxes.reserve(input.visibleBoxes.size());
    for (const scene::Aabb& box : input.visibleBoxes) {
        if (box.empty()) continue;
        boxes.push_back(grown(box, input.cameraPosition));
        coverage.push_back(screenCoverage(input.cameraViewProj, box));
    }

    std::vector<LightDecision> decisions(input.lights.size());
    for (size_t i = 0; i < input.lights.size(); ++i) {
        const scene::Light& light = input.lights[i];
        LightDecision& d = decisions[i];
        const bool shadowed = i < input.shadowed.size() && input.shadowed[i];
        d.fate = shadowed ? LightFate::Shadowed : LightFate::Unshadowed;
        bool inShape = false, inRange = false;
        for (size_t b = 0; b < boxes.size(); ++b) {
            const double bound = lightRadianceBound(light, boxes[b], input.exposure);
            inShape = inShape || bound > 0.0;
            if (bound >= kLightCutoffRadiance) {
                inRange = true;
                d.importance += bound * coverage[b];
            }
        }
        if (!input.cullLights || inRange) continue;
        d.fate = LightFate::Culled;
        const double range = lightRange(light, input.exposure);
        if (!(radianceScale(light, input.exposure) > 0.0)) {
            d.why = "its intensity or colour is 0";
        } else if (boxes.empty()) {
            d.why = "the camera sees no receiver";
        } else if (inShape) {
            d.why = fmt::format("every visible receiver it reaches lies beyond its range of {:.4g} (where its radiance falls "
                                "below {:.3g}, half a display step among {} lights)",
                                range, kLightCutoffRadiance, config::kMaxLights);
        } else if (light.type == scene::LightType::Spot) {
            d.why = fmt::format("its cone ({} degrees from its axis) meets no visible receiver", light.outerConeDeg);
        } else if (light.type == scene::LightType::Rect || light.type == scene::LightType::Disk) {
            d.why = "every visible receiver lies behind its emitting side";
        } else {
            d.why = "it reaches no visible receiver";
        }
    }

    // Shadows on the max_shadowed_lights most important shadowed lights.
    std::vector<size_t> ranked;
    for (size_t i = 0; i < decisions.size(); ++i)
        if (decisions[i].fate == LightFate::Shadowed) ranked.push_back(i);
    std::stable_sort(ranked.begin(), ranked.end(),
                     [&](size_t a, size_t b) { return decisions[a].importance > decisions[b].importance; });
    for (size_t r = input.maxShadowedLights; r < ranked.size(); ++r) {
        LightDecision& d = decisions[ranked[r]];
        d.fate = LightFate::Unshadowed;
        d.why = fmt::format("max_shadowed_lights is {}: it ranks {} of {} shadowed lights by their share of the image",
                            input.maxShadowedLights, r + 1, ranked.size());
    }
    return decisions;
}

namespace {

// Whether `light` can add anything at all in the box: everywhere for point and
// directional lights; a spot within its cone, a rect or disk light in front of its
// emitting side. Both are exact zeros of the shading (its spot factor, its emitter
// cosine); a range is not, so none is used.
bool mayAddIn(const scene::Light& light, const glm::dvec3& lo, const glm::dvec3& hi)
{
    const glm::dvec3 position(light.position);
    const glm::dvec3 axis = glm::normalize(glm::dvec3(light.direction));
    if (light.type == scene::LightType::Spot) {
        const double outer = glm::radians(std::clamp(double(light.outerConeDeg), 0.0, 180.0));
        return coneMeetsBox(position, axis, outer + kConeSlackRad, lo, hi);
    }
    if (light.type == scene::LightType::Rect || light.type == scene::LightType::Disk) {
        const double slack = kReceiverSlack * (glm::length(hi - lo) + glm::length(position));
        for (int c = 0; c < 8; ++c) {
            const glm::dvec3 p((c & 1) ? hi.x : lo.x, (c & 2) ? hi.y : lo.y, (c & 4) ? hi.z : lo.z);
            const double ahead = glm::dot(axis, p - position);
            if (ahead + slack >= 0.0 || std::isnan(ahead)) return true;
        }
        return false;
    }
    return true;
}

// Screen bounds in NDC of the boxes added: their corners in front of the camera, and
// where their edges cross w = kWMin.
struct NdcBounds {
    double xMin = std::numeric_limits<double>::max(), yMin = xMin, xMax = -xMin, yMax = -xMin;
    bool any = false;

    void add(const glm::dvec4& q)
    {
        xMin = std::min(xMin, q.x / q.w);
        xMax = std::max(xMax, q.x / q.w);
        yMin = std::min(yMin, q.y / q.w);
        yMax = std::max(yMax, q.y / q.w);
        any = true;
    }
    void add(const glm::dmat4& viewProj, const glm::dvec3& lo, const glm::dvec3& hi)
    {
        constexpr double kWMin = 1e-6;
        glm::dvec4 clip[8];
        for (int c = 0; c < 8; ++c)
            clip[c] = viewProj * glm::dvec4((c & 1) ? hi.x : lo.x, (c & 2) ? hi.y : lo.y, (c & 4) ? hi.z : lo.z, 1.0);
        for (int c = 0; c < 8; ++c) {
            if (clip[c].w > kWMin) add(clip[c]);
            for (int bit = 0; bit < 3; ++bit) {
                const int d = c | (1 << bit);
                if (d == c) continue;
                const double a = clip[c].w - kWMin, b = clip[d].w - kWMin;
                if ((a > 0.0) != (b > 0.0)) add(clip[c] + (clip[d] - clip[c]) * (a / (a - b)));
            }
        }
    }
    // The part of the screen ([-1, 1]^2) it covers: 1 where it reaches behind the camera.
    double screenShare() const
    {
        if (!any) return 0.0;
        const double w = std::clamp(xMax, -1.0, 1.0) - std::clamp(xMin, -1.0, 1.0);
        const double h = std::clamp(yMax, -1.0, 1.0) - std::clamp(yMin, -1.0, 1.0);
        return std::isfinite(w * h) ? 0.25 * w * h : 1.0;
    }
};

// A box larger than this part of the screen is halved, kRegionSplits times at most, and
// only the halves the light may reach are kept: a ground plane under a spot covers the
// screen, the cone's part of it does not.
constexpr double kRegionSplitShare = 1.0 / 64.0;
constexpr int kRegionSplits = 8;

void addReached(const scene::Light& light, const glm::dmat4& viewProj, const glm::dvec3& lo, const glm::dvec3& hi,
                int splits, NdcBounds& bounds)
{
    if (!mayAddIn(light, lo, hi)) return;
    const bool bounded = light.type == scene::LightType::Spot || light.type == scene::LightType::Rect ||
                         light.type == scene::LightType::Disk;
    if (bounded && splits < kRegionSplits) {
        NdcBounds own;
        own.add(viewProj, lo, hi);
        if (own.screenShare() > kRegionSplitShare) {
            const glm::dvec3 size = hi - lo;
            const int side = size.x >= size.y && size.x >= size.z ? 0 : (size.y >= size.z ? 1 : 2);
            glm::dvec3 midHi = hi, midLo = lo;
            midHi[side] = midLo[side] = 0.5 * (lo[side] + hi[side]);
            addReached(light, viewProj, lo, midHi, splits + 1, bounds);
            addReached(light, viewProj, midLo, hi, splits + 1, bounds);
            return;
        }
    }
    bounds.add(viewProj, lo, hi);
}

} // namespace

ScreenRect lightScreenRect(const scene::Light& light, double exposure, std::span<const scene::Aabb> receivers,
                           const glm::vec3& cameraPosition, const glm::mat4& cameraViewProj, uint32_t width,
                           uint32_t height)
{
    const ScreenRect whole{0, 0, int32_t(width), int32_t(height)};
    const double scale = radianceScale(light, exposure);
    if (std::isnan(scale)) return whole;
    if (!(scale > 0.0)) return {};
    // Every G-buffer position lies in the box of an instance in view, grown as
    // decideLights grows it; a pixel without geometry shows the background whatever the
    // lights add.
    const glm::dmat4 m(cameraViewProj);
    NdcBounds bounds;
    for (const scene::Aabb& receiver : receivers) {
        if (receiver.empty()) continue;
        const scene::Aabb box = grown(receiver, cameraPosition);
        addReached(light, m, glm::dvec3(box.min), glm::dvec3(box.max), 0, bounds);
    }
    if (!bounds.any) return {};
    if (!std::isfinite(bounds.xMin) || !std::isfinite(bounds.xMax) || !std::isfinite(bounds.yMin) ||
        !std::isfinite(bounds.yMax)) {
        return whole;
    }
    // NDC to pixels (y down, as the camera's projection flips it), one pixel of margin.
    const auto pixel = [](double ndc, uint32_t size) { return (ndc * 0.5 + 0.5) * double(size); };
    const auto clampTo = [](double v, uint32_t size) { return int32_t(std::clamp(v, 0.0, double(size))); };
    ScreenRect r;
    r.x0 = clampTo(std::floor(pixel(bounds.xMin, width)) - 1.0, width);
    r.x1 = clampTo(std::ceil(pixel(bounds.xMax, width)) + 1.0, width);
    r.y0 = clampTo(std::floor(pixel(bounds.yMin, height)) - 1.0, height);
    r.y1 = clampTo(std::ceil(pixel(bounds.yMax, height)) + 1.0, height);
    return r.empty() ? ScreenRect{} : r;
}

} // namespace penumbra::frame
