#pragma once
// Which lights can matter to a frame, decided before any pass is declared: a light whose
// influence reaches none of the receivers the camera sees gets no passes and adds nothing
// to shading (culled), and "max_shadowed_lights" keeps shadows on the lights that
// contribute most (the rest are lit unshadowed).
//
// A light's influence, against the world box of every instance in the view frustum (the
// scene's BVH):
//   spot         its outer cone (the shading's spot factor is 0 outside it), within range
//   point        its range
//   rect, disk   the half-space its emitting side faces (the shading's emitter cosine is 0
//                behind it), within range
//   directional  everywhere
// The range is where the light's exposed radiance on a white surface facing it, I / (pi
// d^2), falls below kLightCutoffRadiance. A light of zero intensity or colour reaches
// nothing. Tests are conservative: a box is grown by kReceiverSlack of its distance from
// the camera (more than the G-buffer's position error), and the cone is widened by
// kConeSlackRad, so a light that lights a visible pixel is never culled.
#include "penumbra/config/RenderConfig.h"
#include "penumbra/scene/Scene.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace penumbra::frame {

// The exposed radiance below which a light counts as adding nothing: half an 8-bit step
// at the display transform's steepest slope (6.40 display units per unit of exposed
// radiance, at 0.0088: ACES then sRGB, shaders/common/color.glsl), shared among the
// kMaxLights lights a frame may drop together, so that all of them move no displayed value
// by half a step.
inline constexpr double kDisplaySteepestSlope = 6.40;
inline constexpr double kLightCutoffRadiance = 0.5 / 255.0 / kDisplaySteepestSlope / config::kMaxLights;
// Receiver boxes grow by this fraction of their distance from the camera plus their size:
// a G-buffer position reconstructed from 32-bit depth lies within ~1e-6 of that distance.
inline constexpr double kReceiverSlack = 1e-4;
// Spot cones widen by this angle (radians): the shading's float cone test against a double one.
inline constexpr double kConeSlackRad = 1e-4;

enum class LightFate {
    Shadowed,    // its technique's passes run
    Unshadowed,  // lit, V = 1: technique "none", or below max_shadowed_lights
    Culled,      // reaches no visible receiver: no passes, no light
};

const char* lightFateName(LightFate fate);

// An upper bound of the exposed radiance `light` reflects from any point of `box` (white
// Lambertian, facing it, unoccluded): 0 where it cannot reach the box at all (outside
// its cone, behind its emitting side, zero intensity). Not cut off by range.
double lightRadianceBound(const scene::Light& light, const scene::Aabb& box, double exposure);

// The range beyond which `light` counts as adding nothing (infinite for directional).
double lightRange(const scene::Light& light, double exposure);

struct LightDecision {
    LightFate fate = LightFate::Shadowed;
    // The light's estimated share of the image: its radiance bound on each visible box
    // times the part of the screen the box covers, summed. Ranks lights for
    // max_shadowed_lights.
    double importance = 0.0;
    std::string why;  // Culled and demoted lights: why, for graph, --timings and --stats
};

struct LightCullingInput {
    glm::mat4 cameraViewProj{1.0f};
    glm::vec3 cameraPosition{0.0f};
    double exposure = 1.0;
    std::span<const scene::Light> lights;
    // Per light: whether it asks for shadows (a technique other than "none" that loaded).
    std::vector<bool> shadowed;
    // The world boxes of the instances in the view frustum.
    std::vector<scene::Aabb> visibleBoxes;
    bool cullLights = true;                       // "light_culling"
    uint32_t maxShadowedLights = config::kMaxLights;  // "max_shadowed_lights"
};

// Decides each light's fate. Deterministic: ties in importance keep the lower index.
std::vector<LightDecision> decideLights(const LightCullingInput& input);

// Pixels [x0, x1) x [y0, y1) of a width x height image, top row first.
struct ScreenRect {
    int32_t x0 = 0, y0 = 0, x1 = 0, y1 = 0;
    bool empty() const { return x0 >= x1 || y0 >= y1; }
    bool contains(const ScreenRect& r) const { return x0 <= r.x0 && y0 <= r.y0 && r.x1 <= x1 && r.y1 <= y1; }
    bool operator==(const ScreenRect&) const = default;
};

// The pixels whose receivers `light` can light (frame/FrameRenderer.cpp shades it only
// there): the screen bounds of the parts of `receivers` (the world boxes of the instances
// in view: every G-buffer position lies in one) where the shading's light factors can be
// other than exactly 0 - a spot's cone, the half-space a rect or disk light's emitting
// side faces, everywhere for the others - grown by kReceiverSlack and kConeSlackRad and
// one pixel. Boxes larger than 1/64 of the screen are halved (8 times at most) and only
// the halves the light may reach are kept. Outside it the light adds exactly 0, or the
// pixel shows the background. Empty for a light of zero intensity or colour.
ScreenRect lightScreenRect(const scene::Light& light, double exposure, std::span<const scene::Aabb> receivers,
                           const glm::vec3& cameraPosition, const glm::mat4& cameraViewProj, uint32_t width,
                           uint32_t height);

} // namespace penumbra::frame
