#pragma once
// Parameters that shadow-map techniques reflect alike, worded once so that hard, pcss,
// vssm and the example describe them in the same words. In the plugin module, not beside
// render::ShadowMap: a ParamSpec is plugin ABI (plugin/Plugin.h), and render sits below
// plugin.
#include "penumbra/plugin/Params.h"
#include "penumbra/plugin/Plugin.h"

#include <cstdint>
#include <string_view>

namespace penumbra::plugin {

// The map's texels per face side (the default and the largest are the technique's), the
// rasterizer's constant bias, and the light size that render::softShadowLightSize reads
// (-1: the light's own).
constexpr ParamSpec shadowResolutionParam(double defaultTexels, double maxTexels)
{
    return {"resolution", ParamType::Int, defaultTexels, 16, maxTexels, "texels",
            "shadow-map texels per side of each face (point, rect and disk lights: six faces in a 3 x 2 atlas)"};
}
inline constexpr ParamSpec kShadowDepthBiasParam{
    "depth_bias", ParamType::Float, 4, 0, 1e6, "r",
    "constant rasterizer depth bias away from the light, in Vulkan's minimum resolvable depth differences r"};
// The rasterizer's slope-scaled bias factor (`description` says how the technique scales
// it) and its clamp.
constexpr ParamSpec slopeBiasParam(const char* description)
{
    return {"slope_bias", ParamType::Float, 2, 0, 1000, "", description};
}
inline constexpr ParamSpec kBiasClampParam{"bias_clamp", ParamType::Float, 0, 0, 1, "depth",
                                           "largest rasterizer bias, in NDC depth; 0: no clamp"};
inline constexpr ParamSpec kLightSizeParam{
    "light_size", ParamType::Float, -1, -1, 1e9, "world or deg",
    "-1: the light's own size (rect: sqrt(w h), disk: diameter, directional: angular_diameter_deg; spot and "
    "point: 0, a hard shadow); >= 0: this size instead, in world units (directional: angular diameter in degrees)"};

// The PCSS framework's kernel limits (pcss, vssm: `max_search_radius`,
// `max_filter_radius`): the largest half-width of the blocker search or of the penumbra
// filter, as a fraction of a face's side. Relative to the face, not in texels, so that a
// penumbra keeps its width in the world at every resolution: a limit in texels cut wide
// penumbrae the more the finer the map (16 texels held a 2048-texel face's penumbra to
// 1/64 of the face). The shaders take kernelLimitTexels().
constexpr ParamSpec kernelLimitParam(const char* name, double defaultFraction, const char* description)
{
    return {name, ParamType::Float, defaultFraction, 1e-4, 1, "face", description};
}
inline float kernelLimitTexels(float fraction, uint32_t faceTexels) { return fraction * float(faceTexels); }

// kLightSizeParam's value: -1 or >= 0. Its range, [-1, 1e9], cannot say that the values
// between mean nothing: throws penumbra::ConfigError naming `technique`'s light_size for
// them (a test for < 0 would take -0.5 silently as -1, the light's own size).
float lightSizeOverride(const ParamValues& params, std::string_view technique);

// An Int parameter `name` that sizes a box of taps centred on the receiver's texel (PCF),
// in taps per side: odd values only (ParamSpec::odd), from 1 to `maxTaps` (odd).
constexpr ParamSpec oddKernelParam(const char* name, double defaultTaps, double maxTaps, const char* description)
{
    return {name, ParamType::Int, defaultTaps, 1, maxTaps, "texels", description, nullptr, 0, true};
}

} // namespace penumbra::plugin
