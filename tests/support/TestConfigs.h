#pragma once
// Configs and scenes the rendering tests share: config/default.json at a small output size,
// the same at another scale, its light turned into another type, and the small scenes the
// technique tests build (each with the view and light it is seen under), so that a scene
// named in two tests is one scene.
#include "penumbra/config/Config.h"
#include "penumbra/scene/Scene.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <filesystem>
#include <limits>
#include <ostream>
#include <string>
#include <vector>

namespace penumbra::test {

// Every variant of `document`'s sweep, made (config::SweepVariants makes them one at a
// time; the tests' sweeps are small).
std::vector<config::SweepVariant> everyVariant(const config::ConfigDocument& document);

// config/default.json at 320 x 180. Small image, full-size shadow map: the tests check
// the technique, not the output resolution.
config::RenderConfig defaultTestConfig();

// The same scene and view at another scale: every length times s, intensities times s²
// (but a directional light's, an irradiance) so that irradiance (I / d²) and the image
// stay the same. Nothing in the engine may depend on absolute units.
void scaleConfig(config::RenderConfig& c, float s);

// Makes `light` (the default config's spot light) a light of `type`, placed so that it
// casts shadows in the default scene: a slanted directional light, a point light inside
// the scene box (all six cube faces see casters), rect and disk lights above the grid
// emitting downwards. Spot: unchanged.
void setLightType(config::LightConfig& light, scene::LightType type);

// A light type of a parameterised test, printed by name (ctest lists it).
struct LightCase {
    const char* name;
    scene::LightType type;
    double lightSize = -1.0;  // -1: the light's own (rect 1 x 0.5, disk radius 0.5: setLightType)
    int resolution = 1024;
};
std::ostream& operator<<(std::ostream& os, const LightCase& c);

// Non-finite inputs of the guards' tests.
inline constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
inline constexpr float kInf = std::numeric_limits<float>::infinity();

// A visibility made of 0/1 compares averaged in fp32 counts as 0 or 1 within this.
inline constexpr float kBinaryTolerance = 1e-5f;

// Each component of `actual` within `eps` of `expected`'s, the others named on failure.
void expectNear(const glm::vec3& actual, const glm::vec3& expected, float eps = 1e-5f);

// tests/data/gltf/`name`.
std::filesystem::path gltfFile(const std::string& name);

// A 20 x 20 plane alone at y = 0: a receiver with nothing to cast onto it.
scene::Scene planeScene();

// Adds `mesh` (its bounds computed) to `s`; returns its index.
uint32_t addMesh(scene::Scene& s, scene::Mesh mesh);
// Adds an instance of mesh `mesh` under a new root node `name` placed by `transform`.
uint32_t addInstance(scene::Scene& s, uint32_t mesh, const std::string& name, const glm::mat4& transform);

// A unit box standing on planeScene()'s ground (touching it along its whole foot),
// centred at x = z = 0.
scene::Scene boxOnGroundScene();
// Its view and light: a 0.5 x 0.5 rect light at (-3, 3, 0) facing down, so that the box's
// shadow falls towards +x, from its foot at x = 0.5 to x = 2.25; the camera looks
// straight down on it from (1.3, 2.5, 0). The light's technique is left to the test.
config::RenderConfig boxOnGroundConfig();

// The default config's output with a camera looking straight down (60°, image up = -z)
// from `cameraPosition` at the point below it, and one square rect light of side
// `lightSide` at `lightPosition` emitting downwards (width axis x, intensity 40). The
// scene and the light's shadow settings are left as the default config has them.
config::RenderConfig lookDownRectLightConfig(glm::vec3 cameraPosition, glm::vec3 lightPosition, float lightSide);

// Overlapping blockers at two depths: a 0.3 x 1 x 0.3 pillar on planeScene()'s ground (top
// at y = 1) and a plate of the same size 0.2 above its top.
scene::Scene platformScene();
// Its view and light: a 1 x 1 rect light 3 above the top; the camera looks straight down
// on the top from just below the plate (y = 1.15). The light's technique is the default
// config's.
config::RenderConfig platformConfig();

// planeScene() seen from straight above, from (0, 12, 0.5), under one directional light
// `degreesFromNormal` from the plane's normal, tilted towards +x (every other field of the
// light is scene::Light's default): a receiver nothing shadows, at any angle.
config::RenderConfig planeUnderDirectionalLightConfig(float degreesFromNormal);

// Blended panes of `alpha` ([-1, 1]² at the heights `heights`) over planeScene()'s
// ground, and opaque plates the same size at the heights `opaque`; all of it scaled by
// `scale` about the origin.
scene::Scene panesScene(const std::vector<float>& heights, float alpha, const std::vector<float>& opaque = {},
                        float scale = 1.0f);

// Places makePlane's unit square as a 2 x 2 wall in the plane x = `x` (y in [0, 2],
// z in [-1, 1]), facing +x.
glm::mat4 wallAt(float x);

// Alpha-masked casters: a 4 x 4 quad at height 2 over a 20 x 20 ground, textured half
// transparent (x < 0: alpha 0) and half opaque, alpha-masked.
scene::Scene halfMaskedQuadScene();
// Adds to `s` the alpha-masked material of halfMaskedQuadScene (a 4 x 1 texture whose half
// u < 0.5 has alpha 0, cutoff 0.5) and returns its index.
uint32_t addHalfMaskedMaterial(scene::Scene& s);
// Its view and light: the camera looks down from above; a directional light slanted by
// 1/2 in x per unit of height, so the opaque half's shadow falls on x in [1, 3] and light
// reaches x in (-1, 1) through the transparent half.
config::RenderConfig halfMaskedQuadConfig();

} // namespace penumbra::test
