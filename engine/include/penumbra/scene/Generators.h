#pragma once
// Procedural scenes, deterministic for a seed: the box grid (the default scene), an
// analytic penumbra set-up, a city, hair, a lattice fence and the box field of the
// classic shadow benchmark; scaleScene() puts any of
// them at another scale, and generateScene() builds one by name for the command line.
//
// Conventions: y is up and the ground is the plane y = 0; lengths are in world units
// (metres by convention); every params struct's defaults make a sensible scene. Each
// generator's parameters are a table (generatorParameters: type, default, range, unit,
// doc); an invalid parameter throws penumbra::Error naming the generator, the parameter
// (by its snake_case name, as `penumbra generate --set` and the config spell it), what
// it must be and the value.
// Meshes are shared between instances wherever the geometry repeats.
#include "penumbra/scene/Scene.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace penumbra::scene {

// The most a generated scene may hold, checked from the parameters before anything is
// built (the error names the parameters and what they multiply to): triangles stored in
// its meshes (about 100 bytes each with their vertices: 3 GB) and instances (box-grid,
// box-field: triangles; city: instances; hair and fence stay far below both at their
// largest parameters).
inline constexpr uint64_t kMaxGeneratedTriangles = 32000000;
inline constexpr uint64_t kMaxGeneratedInstances = 4000000;

// ---- box-grid: the foundation's default scene -------------------------------------
// A ground plane, a grid of boxes of varied heights and a sphere.
struct BoxGridParams {
    uint32_t columns = 5;
    uint32_t rows = 5;
    float boxSize = 1.2f;         // footprint edge (world units)
    float spacing = 3.0f;         // centre-to-centre distance
    float minHeight = 0.8f;
    float maxHeight = 2.6f;
    float sphereRadius = 1.6f;
    uint32_t sphereSegments = 96;  // around the equator; rings = segments / 2
    float planeSize = 40.0f;
    uint32_t seed = 1;
};

Scene generateBoxGrid(const BoxGridParams& params);

// ---- penumbra: a soft shadow known in closed form ---------------------------------
// A thin square occluder, axis-aligned and centred above the origin, over a large
// ground plane. Under a rectangular area light parallel to the ground its shadow is
// given exactly by penumbraVisibility().
struct PenumbraParams {
    float occluderSize = 1.0f;        // side of the square occluder
    float occluderThickness = 0.01f;  // in [0, occluder_size / 10]; 0 makes a double-sided quad
    float occluderHeight = 1.0f;      // h: height of the occluder's mid-plane above the ground
    float groundSize = 20.0f;         // side of the square ground plane (> occluder_size)
};

Scene generatePenumbra(const PenumbraParams& params);

// A rectangular area light parallel to the ground, facing down. A zero side makes a
// line light; both zero a point light.
struct RectAreaLight {
    glm::vec3 center{0.0f, 4.0f, 0.0f};  // y is the light plane's height H
    glm::vec2 size{0.5f, 0.5f};          // side lengths along x and z
};

// The fraction of `light`'s area visible from the ground point (x, 0, z) of the
// penumbra scene. A light point l is hidden when the segment from the receiver p to l
// crosses the occluder's plane y = h inside the square |x|, |z| <= s/2. The crossing is
// p + (l - p) h/H, so the hidden light points form the back-projected square
//     l_x in [p_x + (-s/2 - p_x) H/h,  p_x + (s/2 - p_x) H/h]   (likewise in z),
// and since light and back-projection are axis-aligned rectangles in one plane, the
// hidden fraction is the product of the two 1D overlaps divided by the light's sides:
//     V(p) = 1 - overlap_x overlap_z / (w_x w_z).
// Along x the penumbra is w_x h / (H - h) wide, the adaptive-soft-shadows thesis's
// w_Penumbra = (d_Receiver - d_Blocker) w_Light / d_Blocker (eq. 7 of section 3) with
// d_Receiver = H and d_Blocker = H - h.
// A zero light side counts 1 if the light's coordinate lies in the back-projected
// interval, else 0 (a hard edge). Assumptions: the receiver lies on the ground and the
// occluder is infinitely thin at height h; this is exact for occluder_thickness = 0. A
// box of thickness t hides light points whose segments cross any height in
// [h - t/2, h + t/2], which moves the shadow edges by at most |p_x - s/2| H t / (2h^2)
// on the light plane: under 0.7 % of visibility at the shadow edge for the default
// scene and light. Throws Error unless H > h + t/2 and the light's sides are finite
// and >= 0.
double penumbraVisibility(const PenumbraParams& params, const RectAreaLight& light, glm::vec2 receiverXz);

// ---- city: many instances, millions of triangles ------------------------------------
// A square grid of blocks separated by streets, on a ground plane. Each block has
// lots_per_side^2 buildings (boxes of varied heights, some with narrower tiers set back
// on top) inside a sidewalk ring; the kerbs carry parked cars, and the sidewalks street
// lights, trees and bins. Every building tier, car, light, tree part and bin is an
// instance of one of 15 shared meshes. Triangles and instances grow with blocks^2:
// about 6,200 triangles and 77 instances per block with the other defaults, so
// blocks = 13 passes a million triangles (the README lists counts).
struct CityParams {
    uint32_t blocks = 8;          // blocks per side of the square city (blocks^2 in all)
    float blockSize = 60.0f;      // edge of a square block, kerb to kerb
    float streetWidth = 16.0f;    // kerb to kerb between neighbouring blocks
    float sidewalkWidth = 3.0f;   // ring inside each block's kerb that holds no building
    uint32_t lotsPerSide = 3;     // building lots along a block side
    float minHeight = 6.0f;       // building heights: most are low, a few are towers
    float maxHeight = 90.0f;
    float setbackChance = 0.4f;   // chance of a narrower tier on top (tried twice)
    float carDensity = 0.5f;      // fraction of the 6 m kerbside parking slots with a car
    float treeChance = 0.5f;      // chance of a tree in a sidewalk slot without a street light
    uint32_t seed = 1;
};

Scene generateCity(const CityParams& params);

// ---- hair: thousands of thin semi-transparent strands -------------------------------
// An opaque head (a sphere) with strands grown from the upper part of its surface,
// above a ground plane. Each strand is a polyline of `segments` segments that starts
// along the scalp normal, bends down under a gravity-like pull and wanders randomly
// (never into the head), drawn as a camera-independent ribbon of 2 triangles per
// segment that tapers to a third of its width at the tip. Ribbons of even strands lie
// along the head's surface (facing outwards), those of odd strands are turned 90
// degrees about the strand, so that the hair covers the light from most directions.
// All strands form one double-sided mesh with an AlphaMode::Blend material.
struct HairParams {
    uint32_t strands = 12000;     // the deep-shadow-map paper's model has 10,000
    uint32_t segments = 12;       // per strand
    float headRadius = 0.1f;
    float strandLength = 0.3f;    // mean root-to-tip length
    float lengthJitter = 0.25f;   // lengths are uniform in strand_length * [1 - j, 1 + j], j < 1
    float strandWidth = 0.002f;   // ribbon width at the root
    float gravity = 12.0f;        // pull towards -y per unit of length (1/world unit); 0: straight
    float waviness = 0.15f;       // random turn per segment (radians, standard deviation)
    float scalpAngleDeg = 110.0f; // roots cover the cap within this angle of the top of the head
    float alpha = 0.3f;           // the hair material's base alpha
    uint32_t seed = 1;
};

Scene generateHair(const HairParams& params);

// ---- fence: a lattice with many small holes -------------------------------------------
// A thin wall pierced by a grid of square holes (a grid of bars), over a ground plane:
// many small shadow features, the hard case for filtered soft shadows. One closed mesh
// without T-junctions, so no light leaks through cracks. tilt_deg = 90 stands it up
// like a fence, 0 lays it flat like a pergola roof; its centre is `elevation` above the
// ground, and it may not reach into the ground.
struct FenceParams {
    uint32_t holesX = 32;       // holes along the width
    uint32_t holesY = 16;       // holes along the height
    float cell = 0.1f;          // centre-to-centre distance of the holes
    float barWidth = 0.025f;    // bars between holes; holes are cell - bar_width square
    float thickness = 0.02f;    // depth of the lattice
    float tiltDeg = 90.0f;      // angle between the lattice and the ground, in [0, 90]
    float elevation = 1.2f;     // height of the lattice's centre above the ground
    float groundSize = 20.0f;   // side of the square ground plane
};

Scene generateFence(const FenceParams& params);

// ---- box-field: the classic shadow benchmark ---------------------------------------
// `boxes` boxes of random height on a ground plane, as in the osgShadow benchmark scene
// (1,000 boxes: 12,002 triangles in 1,001 meshes): the boxes stand on a square grid of
// ceil(sqrt(boxes)) cells per side, `spacing` apart, each jittered inside its cell, with a
// random height; each box is its own mesh (and material), as a scene graph without
// instancing holds them. `face_divisions` splits each box face into d x d quads, so the
// same field reaches a million triangles (d = 9: 972,002) without changing its shape. The
// ground reaches `margin` beyond the outermost boxes on every side.
struct BoxFieldParams {
    uint32_t boxes = 1000;
    float boxSize = 1.0f;        // footprint edge (world units)
    float spacing = 2.5f;        // cell pitch; > box_size so that boxes never touch
    float minHeight = 0.5f;
    float maxHeight = 4.0f;
    uint32_t faceDivisions = 1;  // quads per box face side: 12 d^2 triangles per box
    float margin = 10.0f;        // ground beyond the field on each side
    uint32_t seed = 1;
};

Scene generateBoxField(const BoxFieldParams& params);

// ---- any scene at any scale ----------------------------------------------------------
// Scales every root node's transform by `factor` about the origin, hence every world
// position and instance bound (meshes stay shared and untouched), and returns `scene`.
// Tested for factors 1e-3 ... 1e5. Throws Error for a non-finite factor or one <= 0.
Scene& scaleScene(Scene& scene, float factor);

// ---- generators by name: their parameters reflected -----------------------------------
// One parameter of a generator, described as a plugin describes its own (plugin/Plugin.h
// ParamSpec: name, type, default, range, unit, doc). `penumbra generate --help`, the
// config reader, the range checks and config/schema/penumbra-config.schema.json (held
// equal by a test) all read these tables. Not ParamSpec itself: that struct is the
// plugin ABI's (the scene layer sits below plugin/), and a generator's lengths need a
// range that leaves its minimum out (> 0).
struct GeneratorParam {
    std::string name;          // snake_case, as --set and the config spell it: "block_size"
    bool whole = false;        // a whole number (the params struct holds a uint32_t), else a float
    double defaultValue = 0;   // the params struct's default
    double minValue = 0;       // the range, inclusive ...
    double maxValue = 0;       // ... (the largest float or uint32_t: finiteness is the only bound)
    bool aboveMin = false;     // ... but minValue itself is out: a length must be > 0
    std::string unit;          // "world", "deg", "" when unitless
    std::string doc;           // one line; a bound that depends on another parameter is here
};

// What a value of `param` must be, for messages and --help: "a whole number in [1, 128]",
// "a finite number > 0", "a number in [0, 1]".
std::string describeRange(const GeneratorParam& param);

// `text` (as --set gives it, a config's string, or a JSON number's text) as a value of
// `param`: nullopt when it is not a number of the parameter's type inside its range.
std::optional<double> parseGeneratorValue(const GeneratorParam& param, std::string_view text);

// "box-grid", "penumbra", "city", "hair", "fence", "box-field".
std::vector<std::string> generatorNames();

// The parameters of `generator` in declaration order. Throws Error for an unknown name.
const std::vector<GeneratorParam>& generatorParameters(const std::string& generator);

// Parameter `name` of `generator`. Throws Error for an unknown generator or parameter,
// with the closest known name ("did you mean") and the list of them.
const GeneratorParam& generatorParameter(const std::string& generator, std::string_view name);

// Builds `generator` with the parameters named in `settings` (name, value as text)
// changed from their defaults; a later setting of the same name wins. Throws Error
// naming the generator and the parameter for an unknown generator or parameter, a value
// that is not of the parameter's type or out of its range ("city: blocks must be a whole
// number in [1, 128], got 0"), or parameters that do not fit together.
Scene generateScene(const std::string& generator, const std::vector<std::pair<std::string, std::string>>& settings);

} // namespace penumbra::scene
