#pragma once
// The penumbra scene (scene/Generators.h generatePenumbra: a 1 x 1 plate h above the
// ground under a square light of side w at height 3, whose penumbra along x is
// w h / (H - h) wide) seen from straight above, and the measures the soft-shadow
// plugin tests take of a visibility image on it: the width of a shadow edge and the
// RMSE against the exact visibility (tests/techniques/test_pcss_plugin.cpp, test_vssm_plugin.cpp).
#include "PluginFrame.h"

#include "penumbra/config/Config.h"
#include "penumbra/scene/Generators.h"

#include <algorithm>
#include <string>
#include <utility>
#include <vector>

namespace penumbra::test {

// The parameters the PCSS-framework plugins (pcss, vssm) share, as their tests vary them.
struct KernelSettings {
    double lightSize = -1.0;  // the light's own
    int resolution = 1024;
    // The kernel limits in texels of `resolution`; the plugins take them as fractions of
    // the face (plugin::kernelLimitParam). 0: the plugin's default.
    double maxSearchTexels = 8.0;
    double maxFilterTexels = 8.0;
    std::string biasMode = "receiver_plane";

    // As setShadow takes them.
    nlohmann::json params() const
    {
        nlohmann::json p = {{"light_size", lightSize}, {"resolution", resolution}, {"bias_mode", biasMode}};
        if (maxSearchTexels > 0.0) p["max_search_radius"] = maxSearchTexels / resolution;
        if (maxFilterTexels > 0.0) p["max_filter_radius"] = maxFilterTexels / resolution;
        return p;
    }
    // Away from penumbrae for a ray-cast comparison: as far as the kernels reach, plus
    // two texels.
    double bandTexels() const { return std::max(maxSearchTexels, maxFilterTexels) + 2.0; }
};

constexpr float kPenumbraLightHeight = 3.0f;

struct PenumbraSetup {
    float lightSide = 0.5f;
    float occluderHeight = 1.0f;
    float occluderThickness = 0.01f;
};

scene::PenumbraParams penumbraParams(const PenumbraSetup& p);

// The camera looks straight down on the ground beside the plate (x in about [0.2, 1.8],
// z in [-0.45, 0.45]), below the plate, so that only the ground is seen. The light's
// technique is left to the test.
config::RenderConfig penumbraConfig(const PenumbraSetup& p);

// The 10 %-90 % width of a shadow edge from (coordinate across the edge, V) samples on
// the ground, V averaged over bins of 1 cm (a filter's per-pixel rotation is noise), the
// umbra at smaller coordinates.
double rampWidth(const std::vector<std::pair<float, float>>& samples);

// The penumbra scene's edge along x, on the ground near z = 0.
double edgeWidth(const RenderedFrame& frame, const std::vector<float>& v);

// A box's shadow's side edge (along z > 0, on the ground) in the slice x +- 2 cm.
double sideEdgeWidth(const RenderedFrame& frame, const std::vector<float>& v, float x);

// The contact shadow of test::boxOnGroundScene() under boxOnGroundConfig()'s light: the
// ground pixels right behind the box's foot (x from 0.5 + 4 texels of `texelWorld` to
// 0.65, |z| <= 0.3), and how many of them have V above `umbraMax`.
struct FootShadow {
    size_t pixels = 0;
    size_t notUmbra = 0;
};
FootShadow footShadow(const RenderedFrame& frame, const std::vector<float>& v, double texelWorld, float umbraMax);

// A technique's edge width on the penumbra scene, the exact one measured the same way,
// and the RMSE of V against the exact visibility over the ground and over the penumbra
// region alone (the ground pixels whose exact V lies in (0.001, 0.999)).
struct PenumbraWidths {
    double technique;
    double exact;
    double rmse;
    double penumbraRmse = 0.0;
};

// `v`: the visibility `frame` rendered of penumbraConfig(p) over generatePenumbra.
PenumbraWidths measurePenumbra(const RenderedFrame& frame, const std::vector<float>& v, const PenumbraSetup& p);

} // namespace penumbra::test
