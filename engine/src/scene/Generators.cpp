#include "penumbra/scene/Generators.h"

#include "penumbra/core/ClosestMatch.h"
#include "penumbra/core/Error.h"
#include "penumbra/core/ShortText.h"

#include <fmt/format.h>
#include <glm/gtc/constants.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <functional>
#include <limits>
#include <random>

namespace penumbra::scene {
namespace {

constexpr float kFloatMax = std::numeric_limits<float>::max();

// ---- parameter checks ------------------------------------------------------------------

// The checks of bounds that depend on another parameter (each parameter's own range is
// its table's: checkRanges below). Messages name the generator and the parameter as the
// command line spells it: "city: sidewalk_width must be in [1.5, 15], got 20".
// Every float check is written so that NaN fails it.
class ParamCheck {
public:
    explicit ParamCheck(const char* generator) : generator_(generator) {}

    [[noreturn]] void fail(const char* name, const std::string& requirement, const std::string& got) const
    {
        throw Error(fmt::format("{}: {} must be {}, got {}", generator_, name, requirement, got));
    }
    void range(const char* name, float v, float lo, float hi) const
    {
        if (!(v >= lo && v <= hi)) fail(name, fmt::format("in [{}, {}]", lo, hi), fmt::format("{}", v));
    }
    // v >= the parameter `other`, whose value is lo.
    void atLeast(const char* name, float v, const char* other, float lo) const
    {
        if (!(v >= lo && v <= kFloatMax)) fail(name, fmt::format("a finite number >= {} ({})", other, lo), fmt::format("{}", v));
    }
    // What the parameters multiply to, checked before anything is built: each may lie in
    // its range while their product exhausts memory (box-field boxes=1000000
    // face_divisions=64: 49 billion triangles). `formula` names the parameters, `values`
    // gives their values in the same form.
    void total(const char* what, uint64_t value, uint64_t limit, const std::string& formula,
               const std::string& values) const
    {
        if (value <= limit) return;
        throw Error(fmt::format("{}: {} = {} = {} {}; a generated scene holds at most {} {}", generator_, formula, values,
                                value, what, limit, what));
    }

private:
    const char* generator_;
};

// ---- randomness ----------------------------------------------------------------------

// Variates computed from mt19937's raw output, which the C++ standard fixes; the std
// distributions are implementation-defined, so a scene built with them could differ
// between standard libraries for one seed. (The box grid keeps its std distributions:
// its scenes must not change.)
class Random {
public:
    explicit Random(uint32_t seed) : engine_(seed) {}
    float uniform() { return float(engine_() >> 8) * 0x1p-24f; }  // [0, 1)
    float uniform(float lo, float hi) { return lo + (hi - lo) * uniform(); }
    bool chance(float p) { return uniform() < p; }
    uint32_t below(uint32_t n) { return std::min(n - 1, uint32_t(uniform() * float(n))); }
    float normal()  // Box–Muller
    {
        const float u1 = 1.0f - uniform(), u2 = uniform();
        return std::sqrt(-2.0f * std::log(u1)) * std::cos(glm::two_pi<float>() * u2);
    }

private:
    std::mt19937 engine_;
};

// ---- transforms and mesh pieces --------------------------------------------------------

const glm::vec3 kUp{0.0f, 1.0f, 0.0f};

glm::mat4 translation(const glm::vec3& t) { return glm::translate(glm::mat4(1.0f), t); }
glm::mat4 translationScale(const glm::vec3& t, const glm::vec3& s) { return glm::scale(translation(t), s); }

// Places a local frame at `position` with its +x along the horizontal unit vector
// `along` and +y up.
glm::mat4 facing(const glm::vec3& position, const glm::vec3& along)
{
    glm::mat4 m(1.0f);
    m[0] = glm::vec4(along, 0.0f);
    m[1] = glm::vec4(kUp, 0.0f);
    m[2] = glm::vec4(glm::cross(along, kUp), 0.0f);
    m[3] = glm::vec4(position, 1.0f);
    return m;
}

// Appends `part` to `mesh`, positions transformed by `m` and normals by its inverse
// transpose, so that several primitives make one mesh (one material).
void appendTransformed(Mesh& mesh, const Mesh& part, const glm::mat4& m)
{
    const glm::mat3 normalMatrix = glm::transpose(glm::inverse(glm::mat3(m)));
    const auto base = static_cast<uint32_t>(mesh.vertices.size());
    for (const Vertex& v : part.vertices) {
        mesh.vertices.push_back({glm::vec3(m * glm::vec4(v.position, 1.0f)), glm::normalize(normalMatrix * v.normal), v.uv});
    }
    for (uint32_t i : part.indices) mesh.indices.push_back(base + i);
}

// Adds the quad p[0..3] (in order around its edge) facing `n`, with its own vertices.
void addQuad(Mesh& mesh, const std::array<glm::vec3, 4>& p, const glm::vec3& n)
{
    const auto base = static_cast<uint32_t>(mesh.vertices.size());
    const glm::vec2 uv[4] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    for (int i = 0; i < 4; ++i) mesh.vertices.push_back({p[i], n, uv[i]});
    if (glm::dot(glm::cross(p[1] - p[0], p[2] - p[0]), n) > 0.0f) {
        mesh.indices.insert(mesh.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
    } else {
        mesh.indices.insert(mesh.indices.end(), {base, base + 2, base + 1, base, base + 3, base + 2});
    }
}

// Unit radius, axis y, y in [-0.5, 0.5]; smooth sides, flat caps.
Mesh makeCylinder(const std::string& name, uint32_t segments)
{
    Mesh mesh{name, {}, {}};
    for (uint32_t s = 0; s <= segments; ++s) {
        const float phi = glm::two_pi<float>() * float(s) / float(segments);
        const glm::vec3 n{std::cos(phi), 0.0f, std::sin(phi)};
        const float u = float(s) / float(segments);
        mesh.vertices.push_back({n - 0.5f * kUp, n, {u, 0.0f}});
        mesh.vertices.push_back({n + 0.5f * kUp, n, {u, 1.0f}});
    }
    for (uint32_t s = 0; s < segments; ++s) {
        const uint32_t bottom = 2 * s, top = bottom + 1, nextBottom = bottom + 2, nextTop = bottom + 3;
        // phi grows from +x towards +z, so this order faces outwards.
        mesh.indices.insert(mesh.indices.end(), {bottom, top, nextTop, bottom, nextTop, nextBottom});
    }
    for (const float side : {-1.0f, 1.0f}) {
        const auto base = static_cast<uint32_t>(mesh.vertices.size());
        for (uint32_t s = 0; s < segments; ++s) {
            const float phi = glm::two_pi<float>() * float(s) / float(segments);
            const glm::vec2 c{std::cos(phi), std::sin(phi)};
            mesh.vertices.push_back({{c.x, 0.5f * side, c.y}, side * kUp, 0.5f * (c + 1.0f)});
        }
        for (uint32_t s = 1; s + 1 < segments; ++s) {
            // Seen from +y, growing phi runs clockwise: the top cap reverses it.
            if (side > 0) mesh.indices.insert(mesh.indices.end(), {base, base + s + 1, base + s});
            else mesh.indices.insert(mesh.indices.end(), {base, base + s, base + s + 1});
        }
    }
    return mesh;
}

// The unit cube [-0.5, 0.5]^3 with each face split into `divisions` x `divisions` quads
// (flat normals, each face its own vertices): makeBox's cube for divisions = 1.
Mesh makeDividedBox(const std::string& name, uint32_t divisions)
{
    Mesh mesh{name, {}, {}};
    const glm::vec3 normals[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    const uint32_t side = divisions + 1;
    for (const glm::vec3& n : normals) {
        const glm::vec3 t = std::abs(n.y) > 0.5f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
        const glm::vec3 b = glm::cross(n, t);
        const auto base = static_cast<uint32_t>(mesh.vertices.size());
        for (uint32_t j = 0; j < side; ++j) {
            for (uint32_t i = 0; i < side; ++i) {
                const glm::vec2 uv{float(i) / float(divisions), float(j) / float(divisions)};
                const glm::vec2 c = 2.0f * uv - 1.0f;
                mesh.vertices.push_back({0.5f * (n + c.x * t + c.y * b), n, uv});
            }
        }
        // t × b = n, so (i, j) -> (i + 1, j) -> (i + 1, j + 1) runs counter-clockwise
        // seen from outside.
        for (uint32_t j = 0; j < divisions; ++j) {
            for (uint32_t i = 0; i < divisions; ++i) {
                const uint32_t v00 = base + j * side + i, v10 = v00 + 1, v01 = v00 + side, v11 = v01 + 1;
                mesh.indices.insert(mesh.indices.end(), {v00, v10, v11, v00, v11, v01});
            }
        }
    }
    return mesh;
}

// Assembles a generated scene under one root node: meshes (each with its own
// material), nodes and instances.
class SceneBuilder {
public:
    explicit SceneBuilder(const std::string& rootName) : root_(scene_.graph.addNode(rootName, kNoParent, glm::mat4(1.0f))) {}

    uint32_t root() const { return root_; }

    uint32_t addMesh(Mesh mesh, const Material& material)
    {
        mesh.material = static_cast<uint32_t>(scene_.materials.size());
        mesh.computeBounds();
        scene_.materials.push_back(material);
        scene_.meshes.push_back(std::move(mesh));
        return static_cast<uint32_t>(scene_.meshes.size() - 1);
    }

    uint32_t addNode(const std::string& name, uint32_t parent, const glm::mat4& local)
    {
        return scene_.graph.addNode(name, static_cast<int32_t>(parent), local);
    }

    // A node under `parent` holding one instance of `mesh`.
    uint32_t place(uint32_t mesh, const std::string& name, uint32_t parent, const glm::mat4& local)
    {
        const uint32_t node = addNode(name, parent, local);
        scene_.addInstance(mesh, node);
        return node;
    }

    Scene finish() { return std::move(scene_); }

private:
    Scene scene_;
    uint32_t root_;
};

uint32_t addGround(SceneBuilder& b, float size)
{
    const uint32_t mesh = b.addMesh(makePlane("ground"), Material{"ground", {0.75f, 0.75f, 0.72f, 1.0f}});
    return b.place(mesh, "ground", b.root(), glm::scale(glm::mat4(1.0f), glm::vec3(size, 1.0f, size)));
}

// ---- city pieces -------------------------------------------------------------------------

constexpr float kParkingSlot = 6.0f;    // kerb length per parked car or sidewalk item
constexpr uint32_t kLightEvery = 4;     // a street light in every 4th sidewalk slot
constexpr float kBinChance = 0.25f;     // a bin in a sidewalk slot without light or tree
constexpr float kKerbToCar = 1.3f;      // kerb to a parked car's centre line
constexpr float kKerbToLight = 0.5f;    // kerb to a street light's pole

// 4.4 m long (+x), 1.8 m wide, body, cabin and four wheels; 168 triangles.
Mesh makeCar(const std::string& name)
{
    Mesh car{name, {}, {}};
    const Mesh box = makeBox("box"), wheel = makeCylinder("wheel", 10);
    appendTransformed(car, box, translationScale({0.0f, 0.675f, 0.0f}, {4.4f, 0.75f, 1.8f}));
    appendTransformed(car, box, translationScale({-0.2f, 1.35f, 0.0f}, {2.4f, 0.6f, 1.6f}));
    for (const float x : {-1.4f, 1.4f}) {
        for (const float z : {-0.8f, 0.8f}) {
            // The cylinder's axis (y) turned to z.
            const glm::mat4 m = glm::rotate(translation({x, 0.32f, z}), glm::half_pi<float>(), glm::vec3(1, 0, 0));
            appendTransformed(car, wheel, glm::scale(m, glm::vec3(0.32f, 0.22f, 0.32f)));
        }
    }
    return car;
}

// A 6 m pole with an arm reaching 1.5 m over the street (+x); 52 triangles.
Mesh makeStreetLight(const std::string& name)
{
    Mesh light{name, {}, {}};
    const Mesh box = makeBox("box");
    appendTransformed(light, makeCylinder("pole", 8), translationScale({0.0f, 3.0f, 0.0f}, {0.08f, 6.0f, 0.08f}));
    appendTransformed(light, box, translationScale({0.75f, 5.9f, 0.0f}, {1.5f, 0.08f, 0.08f}));
    appendTransformed(light, box, translationScale({1.4f, 5.8f, 0.0f}, {0.5f, 0.15f, 0.3f}));
    return light;
}

struct CityMeshes {
    std::array<uint32_t, 6> facades{};
    std::array<uint32_t, 4> cars{};
    uint32_t streetLight = 0, trunk = 0, canopy = 0, bin = 0;
};

CityMeshes addCityMeshes(SceneBuilder& b)
{
    CityMeshes m;
    const glm::vec3 facadeColors[6] = {{0.72f, 0.68f, 0.62f}, {0.55f, 0.57f, 0.6f}, {0.78f, 0.74f, 0.66f},
                                       {0.48f, 0.42f, 0.38f}, {0.66f, 0.7f, 0.74f},  {0.82f, 0.8f, 0.78f}};
    for (size_t i = 0; i < m.facades.size(); ++i) {
        const std::string name = fmt::format("facade_{}", i);
        m.facades[i] = b.addMesh(makeBox(name), Material{name, glm::vec4(facadeColors[i], 1.0f)});
    }
    const glm::vec3 carColors[4] = {{0.7f, 0.1f, 0.08f}, {0.1f, 0.2f, 0.55f}, {0.85f, 0.85f, 0.82f}, {0.12f, 0.12f, 0.13f}};
    for (size_t i = 0; i < m.cars.size(); ++i) {
        const std::string name = fmt::format("car_{}", i);
        m.cars[i] = b.addMesh(makeCar(name), Material{name, glm::vec4(carColors[i], 1.0f)});
    }
    m.streetLight = b.addMesh(makeStreetLight("street_light"), Material{"street_light", {0.3f, 0.31f, 0.33f, 1.0f}});
    m.trunk = b.addMesh(makeCylinder("trunk", 8), Material{"bark", {0.35f, 0.25f, 0.17f, 1.0f}});
    m.canopy = b.addMesh(makeSphere("canopy", 12), Material{"leaves", {0.22f, 0.45f, 0.18f, 1.0f}});
    m.bin = b.addMesh(makeBox("bin"), Material{"bin", {0.2f, 0.3f, 0.22f, 1.0f}});
    return m;
}

// Tiers of one building on a lot of side `lot` centred at the building node.
void addBuilding(SceneBuilder& b, const CityParams& p, const CityMeshes& meshes, Random& rng, uint32_t building,
                 float lot)
{
    const uint32_t facade = meshes.facades[rng.below(uint32_t(meshes.facades.size()))];
    // Cubed: most buildings are low, a few are towers.
    const float u = rng.uniform();
    const float height = p.minHeight + (p.maxHeight - p.minHeight) * u * u * u;
    glm::vec2 footprint{lot * rng.uniform(0.6f, 0.9f), lot * rng.uniform(0.6f, 0.9f)};
    uint32_t setbacks = 0;
    while (setbacks < 2 && rng.chance(p.setbackChance)) ++setbacks;
    float bottom = 0.0f;
    for (uint32_t tier = 0; tier <= setbacks; ++tier) {
        const float remaining = height - bottom;
        const float tierHeight = tier == setbacks ? remaining : remaining * rng.uniform(0.4f, 0.7f);
        b.place(facade, fmt::format("tier_{}", tier), building,
                translationScale({0.0f, bottom + 0.5f * tierHeight, 0.0f}, {footprint.x, tierHeight, footprint.y}));
        bottom += tierHeight;
        footprint *= glm::vec2(rng.uniform(0.55f, 0.85f), rng.uniform(0.55f, 0.85f));
    }
}

void addTree(SceneBuilder& b, const CityMeshes& meshes, Random& rng, uint32_t parent, const glm::vec3& position)
{
    const uint32_t tree = b.addNode("tree", parent, glm::scale(translation(position), glm::vec3(rng.uniform(0.8f, 1.2f))));
    b.place(meshes.trunk, "trunk", tree, translationScale({0.0f, 1.25f, 0.0f}, {0.15f, 2.5f, 0.15f}));
    b.place(meshes.canopy, "canopy", tree, translationScale({0.0f, 3.8f, 0.0f}, {1.8f, 2.0f, 1.8f}));
}

// Parked cars along the kerb and street furniture along the sidewalk of one block edge.
void addKerbside(SceneBuilder& b, const CityParams& p, const CityMeshes& meshes, Random& rng, uint32_t block,
                 const glm::vec3& start, const glm::vec3& along)
{
    const glm::vec3 outward = glm::cross(kUp, along);  // from the block into the street
    const uint32_t slots = std::max(1u, uint32_t(p.blockSize / kParkingSlot));
    const float slot = p.blockSize / float(slots);
    for (uint32_t k = 0; k < slots; ++k) {
        const glm::vec3 kerb = start + along * ((float(k) + 0.5f) * slot);
        if (rng.chance(p.carDensity)) {
            const glm::vec3 at = kerb + outward * kKerbToCar + along * rng.uniform(-0.4f, 0.4f);
            b.place(meshes.cars[rng.below(uint32_t(meshes.cars.size()))], "car", block, facing(at, along));
        }
        if (k % kLightEvery == kLightEvery / 2) {
            b.place(meshes.streetLight, "street_light", block, facing(kerb - outward * kKerbToLight, outward));
        } else if (rng.chance(p.treeChance)) {
            addTree(b, meshes, rng, block, kerb - outward * (0.5f * p.sidewalkWidth));
        } else if (rng.chance(kBinChance)) {
            b.place(meshes.bin, "bin", block, translationScale(kerb - outward * 0.5f + 0.5f * kUp, {0.6f, 1.0f, 0.6f}));
        }
    }
}

// ---- hair pieces ---------------------------------------------------------------------------

constexpr float kRootLift = 1.005f;   // roots sit this factor of the radius (plus half a width) out
constexpr float kHeadClear = 1.02f;   // strands stay this factor of the radius out, or move outwards
constexpr float kRootTilt = 0.6f;     // roots lean this much (tan) from the normal towards -y
constexpr float kTipWidth = 1.0f / 3.0f;

glm::vec3 anyPerpendicular(const glm::vec3& v)
{
    const glm::vec3 axis = std::abs(v.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 0, 1);
    return glm::normalize(glm::cross(v, axis));
}

// `d` without its component along the head's radial direction at `p`: the step slides
// over the head instead of entering it.
glm::vec3 tangential(const glm::vec3& d, const glm::vec3& p)
{
    const glm::vec3 r = glm::normalize(p);
    for (const glm::vec3& v : {d, -kUp}) {
        const glm::vec3 t = v - glm::dot(v, r) * r;
        if (glm::length(t) > 1e-3f) return glm::normalize(t);
    }
    return anyPerpendicular(r);
}

// The strand's points, root first, `segments` steps of equal length (never zero, so
// ribbon triangles never degenerate) grown relative to the head's centre.
std::vector<glm::vec3> growStrand(const HairParams& p, Random& rng, float theta, float phi, float length)
{
    const glm::vec3 radial{std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi)};
    const glm::vec3 meridianDown{std::cos(theta) * std::cos(phi), -std::sin(theta), std::cos(theta) * std::sin(phi)};
    const float step = length / float(p.segments);
    // A ribbon's edge lies half a width from its point, and every point lies farther
    // out than the root: no ribbon vertex enters the head.
    const float halfWidth = 0.5f * p.strandWidth;
    std::vector<glm::vec3> points{radial * (p.headRadius * kRootLift + halfWidth)};
    glm::vec3 d = glm::normalize(radial + kRootTilt * meridianDown);
    for (uint32_t k = 0; k < p.segments; ++k) {
        if (k > 0) {
            const glm::vec3 wander{rng.normal(), rng.normal(), rng.normal()};
            d = glm::normalize(d - p.gravity * step * kUp + p.waviness * wander);
        }
        const glm::vec3 from = points.back();
        if (glm::length(from + d * step) < p.headRadius * kHeadClear + halfWidth) d = tangential(d, from);
        points.push_back(from + d * step);
    }
    return points;
}

// Appends the strand as a ribbon: two vertices per point, across `side`, two
// triangles per segment. Even strands' ribbons lie along the head (their width along
// the parallel of latitude through the root), odd strands' are turned 90 degrees.
void appendRibbon(Mesh& mesh, const HairParams& p, const std::vector<glm::vec3>& points, float phi, bool turned)
{
    const auto base = static_cast<uint32_t>(mesh.vertices.size());
    const size_t n = points.size() - 1;
    glm::vec3 across{-std::sin(phi), 0.0f, std::cos(phi)};
    for (size_t k = 0; k <= n; ++k) {
        const glm::vec3 before = glm::normalize(points[k == 0 ? 1 : k] - points[k == 0 ? 0 : k - 1]);
        const glm::vec3 after = glm::normalize(points[k == n ? n : k + 1] - points[k == n ? n - 1 : k]);
        const glm::vec3 sum = before + after;
        const glm::vec3 tangent = glm::length(sum) > 1e-6f ? glm::normalize(sum) : after;
        // Carry the width direction along the strand, kept perpendicular to it.
        across -= glm::dot(across, tangent) * tangent;
        across = glm::length(across) > 1e-4f ? glm::normalize(across) : anyPerpendicular(tangent);
        const glm::vec3 side = turned ? glm::cross(tangent, across) : across;
        const glm::vec3 normal = glm::cross(side, tangent);
        const float v = float(k) / float(n);
        const float halfWidth = 0.5f * p.strandWidth * (1.0f - (1.0f - kTipWidth) * v);
        mesh.vertices.push_back({points[k] - side * halfWidth, normal, {0.0f, v}});
        mesh.vertices.push_back({points[k] + side * halfWidth, normal, {1.0f, v}});
    }
    for (uint32_t k = 0; k < n; ++k) {
        const uint32_t a = base + 2 * k, b = a + 1, c = a + 2, d = a + 3;
        // (b - a) x (d - a) points along cross(side, tangent), the normal.
        mesh.indices.insert(mesh.indices.end(), {a, b, d, a, d, c});
    }
}

Mesh makeHair(const HairParams& p, Random& rng)
{
    Mesh hair{"hair", {}, {}};
    hair.vertices.reserve(size_t(p.strands) * 2 * (p.segments + 1));
    hair.indices.reserve(size_t(p.strands) * 6 * p.segments);
    const float cosScalp = std::cos(glm::radians(p.scalpAngleDeg));
    for (uint32_t s = 0; s < p.strands; ++s) {
        // Uniform over the spherical cap: cos(theta) uniform.
        const float theta = std::acos(rng.uniform(cosScalp, 1.0f));
        const float phi = rng.uniform(0.0f, glm::two_pi<float>());
        const float length = p.strandLength * rng.uniform(1.0f - p.lengthJitter, 1.0f + p.lengthJitter);
        appendRibbon(hair, p, growStrand(p, rng, theta, phi, length), phi, s % 2 == 1);
    }
    return hair;
}

// ---- lattice pieces ------------------------------------------------------------------------

// Both edges of every bar across one direction, centred on 0: odd intervals between
// consecutive values are holes, even ones bars.
std::vector<float> barEdges(uint32_t holes, float cell, float bar)
{
    const float extent = float(holes) * cell + bar;
    std::vector<float> edges;
    for (uint32_t i = 0; i <= holes; ++i) {
        const float x = -0.5f * extent + float(i) * cell;
        edges.push_back(x);
        edges.push_back(x + bar);
    }
    return edges;
}

// The lattice in its own frame: width along x, height along y, thickness along z,
// centred on the origin. The front and back faces are grids over all bar edges, so a
// hole wall's edge is always a whole grid edge: no T-junctions.
Mesh makeLattice(const FenceParams& p)
{
    Mesh mesh{"lattice", {}, {}};
    const std::vector<float> xs = barEdges(p.holesX, p.cell, p.barWidth), ys = barEdges(p.holesY, p.cell, p.barWidth);
    const auto nx = static_cast<uint32_t>(xs.size()), ny = static_cast<uint32_t>(ys.size());
    const float hz = 0.5f * p.thickness;
    auto isHole = [](uint32_t ix, uint32_t iy) { return ix % 2 == 1 && iy % 2 == 1; };
    const glm::vec2 extent{xs.back() - xs.front(), ys.back() - ys.front()};

    for (const float face : {1.0f, -1.0f}) {
        const auto base = static_cast<uint32_t>(mesh.vertices.size());
        for (uint32_t iy = 0; iy < ny; ++iy) {
            for (uint32_t ix = 0; ix < nx; ++ix) {
                mesh.vertices.push_back({{xs[ix], ys[iy], face * hz}, {0.0f, 0.0f, face},
                                         glm::vec2(xs[ix], ys[iy]) / extent + 0.5f});
            }
        }
        for (uint32_t iy = 0; iy + 1 < ny; ++iy) {
            for (uint32_t ix = 0; ix + 1 < nx; ++ix) {
                if (isHole(ix, iy)) continue;
                const uint32_t a = base + iy * nx + ix, b = a + 1, c = a + nx + 1, d = a + nx;
                // Counter-clockwise seen from +z; the back face reverses it.
                if (face > 0) mesh.indices.insert(mesh.indices.end(), {a, b, c, a, c, d});
                else mesh.indices.insert(mesh.indices.end(), {a, c, b, a, d, c});
            }
        }
    }
    // Walls of each hole, facing into it.
    for (uint32_t iy = 1; iy + 1 < ny; iy += 2) {
        for (uint32_t ix = 1; ix + 1 < nx; ix += 2) {
            const float x0 = xs[ix], x1 = xs[ix + 1], y0 = ys[iy], y1 = ys[iy + 1];
            addQuad(mesh, {{{x0, y0, -hz}, {x0, y1, -hz}, {x0, y1, hz}, {x0, y0, hz}}}, {1, 0, 0});
            addQuad(mesh, {{{x1, y0, -hz}, {x1, y1, -hz}, {x1, y1, hz}, {x1, y0, hz}}}, {-1, 0, 0});
            addQuad(mesh, {{{x0, y0, -hz}, {x1, y0, -hz}, {x1, y0, hz}, {x0, y0, hz}}}, {0, 1, 0});
            addQuad(mesh, {{{x0, y1, -hz}, {x1, y1, -hz}, {x1, y1, hz}, {x0, y1, hz}}}, {0, -1, 0});
        }
    }
    // The outer rim, split at every grid line like the faces it joins.
    for (uint32_t iy = 0; iy + 1 < ny; ++iy) {
        for (const float x : {xs.front(), xs.back()}) {
            const float y0 = ys[iy], y1 = ys[iy + 1];
            addQuad(mesh, {{{x, y0, -hz}, {x, y1, -hz}, {x, y1, hz}, {x, y0, hz}}}, {x > 0 ? 1.0f : -1.0f, 0, 0});
        }
    }
    for (uint32_t ix = 0; ix + 1 < nx; ++ix) {
        for (const float y : {ys.front(), ys.back()}) {
            const float x0 = xs[ix], x1 = xs[ix + 1];
            addQuad(mesh, {{{x0, y, -hz}, {x1, y, -hz}, {x1, y, hz}, {x0, y, hz}}}, {0, y > 0 ? 1.0f : -1.0f, 0});
        }
    }
    return mesh;
}

// Fraction of the light interval [lightMin, lightMax] inside [hiddenMin, hiddenMax];
// for a zero-length light interval (a point along this axis) 1 or 0.
double hiddenFraction(double lightMin, double lightMax, double hiddenMin, double hiddenMax)
{
    if (lightMax <= lightMin) return lightMin >= hiddenMin && lightMin <= hiddenMax ? 1.0 : 0.0;
    const double overlap = std::min(lightMax, hiddenMax) - std::max(lightMin, hiddenMin);
    return std::clamp(overlap / (lightMax - lightMin), 0.0, 1.0);
}

// ---- generators by name ------------------------------------------------------------------

// One row of a generator's table: the reflected parameter and the params struct's field
// it sets (a uint32_t for a whole number, a float otherwise).
template <class Params> struct Field {
    GeneratorParam param;
    uint32_t Params::*wholeMember = nullptr;
    float Params::*realMember = nullptr;
};

// A float's shortest decimal form as a double (0.1f: 0.1, not 0.10000000149), so that a
// default reads as the struct's source writes it.
double decimal(float v)
{
    double d = 0.0;
    const std::string text = fmt::format("{}", v);
    std::from_chars(text.data(), text.data() + text.size(), d);
    return d;
}

template <class Params>
Field<Params> whole(const char* name, uint32_t Params::*member, uint32_t lo, uint32_t hi, const char* doc)
{
    return {{name, true, double(Params{}.*member), double(lo), double(hi), false, "", doc}, member, nullptr};
}

template <class Params> Field<Params> seed(uint32_t Params::*member)
{
    return whole("seed", member, 0, std::numeric_limits<uint32_t>::max(), "seed of the generator's random choices");
}

// A float in [lo, hi] (hi = kFloatMax: any finite value from lo).
template <class Params>
Field<Params> real(const char* name, float Params::*member, float lo, float hi, const char* unit, const char* doc)
{
    return {{name, false, decimal(Params{}.*member), decimal(lo), decimal(hi), false, unit, doc}, nullptr, member};
}

// A float > 0 (and at most hi): a length, a size.
template <class Params>
Field<Params> positive(const char* name, float Params::*member, const char* unit, const char* doc, float hi = kFloatMax)
{
    Field<Params> f = real(name, member, 0.0f, hi, unit, doc);
    f.param.aboveMin = true;
    return f;
}

// The snake_case names (command line, config) of each params struct's fields, with their
// ranges; bounds that depend on another parameter are checked by the generator itself.
const std::vector<Field<BoxGridParams>>& fields(const BoxGridParams*)
{
    using P = BoxGridParams;
    static const std::vector<Field<P>> table = {
        whole("columns", &P::columns, 1, 1024, "boxes along x"),
        whole("rows", &P::rows, 1, 1024, "boxes along z"),
        positive("box_size", &P::boxSize, "world", "footprint edge of a box"),
        positive("spacing", &P::spacing, "world", "centre-to-centre distance of the boxes"),
        positive("min_height", &P::minHeight, "world", "the lowest box height"),
        positive("max_height", &P::maxHeight, "world", "the highest box height; >= min_height"),
        positive("sphere_radius", &P::sphereRadius, "world", "radius of the sphere"),
        whole("sphere_segments", &P::sphereSegments, 3, 4096, "segments around the sphere's equator; rings: half as many"),
        positive("plane_size", &P::planeSize, "world", "side of the square ground plane"),
        seed(&P::seed),
    };
    return table;
}

const std::vector<Field<PenumbraParams>>& fields(const PenumbraParams*)
{
    using P = PenumbraParams;
    static const std::vector<Field<P>> table = {
        positive("occluder_size", &P::occluderSize, "world", "side of the square occluder"),
        real("occluder_thickness", &P::occluderThickness, 0.0f, kFloatMax, "world",
             "<= occluder_size / 10; 0 makes a double-sided quad"),
        positive("occluder_height", &P::occluderHeight, "world",
                 "height of the occluder's mid-plane above the ground; > occluder_thickness / 2"),
        positive("ground_size", &P::groundSize, "world", "side of the square ground plane; >= occluder_size"),
    };
    return table;
}

const std::vector<Field<CityParams>>& fields(const CityParams*)
{
    using P = CityParams;
    static const std::vector<Field<P>> table = {
        whole("blocks", &P::blocks, 1, 128, "blocks per side of the square city (blocks² in all)"),
        real("block_size", &P::blockSize, 10.0f, 1000.0f, "world", "edge of a square block, kerb to kerb"),
        real("street_width", &P::streetWidth, 5.0f, 200.0f, "world", "kerb to kerb between neighbouring blocks"),
        real("sidewalk_width", &P::sidewalkWidth, 1.5f, 250.0f, "world",
             "ring inside each block's kerb that holds no building; <= block_size / 4"),
        whole("lots_per_side", &P::lotsPerSide, 1, 16, "building lots along a block side"),
        positive("min_height", &P::minHeight, "world", "building heights: most are low, a few are towers"),
        positive("max_height", &P::maxHeight, "world", "the tallest building; >= min_height", 10000.0f),
        real("setback_chance", &P::setbackChance, 0.0f, 1.0f, "", "chance of a narrower tier on top (tried twice)"),
        real("car_density", &P::carDensity, 0.0f, 1.0f, "", "fraction of the 6 m kerbside parking slots with a car"),
        real("tree_chance", &P::treeChance, 0.0f, 1.0f, "", "chance of a tree in a sidewalk slot without a street light"),
        seed(&P::seed),
    };
    return table;
}

const std::vector<Field<HairParams>>& fields(const HairParams*)
{
    using P = HairParams;
    static const std::vector<Field<P>> table = {
        whole("strands", &P::strands, 1, 100000, "strands on the scalp"),
        whole("segments", &P::segments, 1, 64, "segments per strand"),
        positive("head_radius", &P::headRadius, "world", "radius of the head (a sphere)"),
        positive("strand_length", &P::strandLength, "world", "mean root-to-tip length"),
        real("length_jitter", &P::lengthJitter, 0.0f, 0.9f, "", "lengths are uniform in strand_length × [1 - j, 1 + j]"),
        positive("strand_width", &P::strandWidth, "world", "ribbon width at the root"),
        real("gravity", &P::gravity, 0.0f, 1e6f, "1/world", "pull towards -y per unit of length; 0: straight strands"),
        real("waviness", &P::waviness, 0.0f, 1.0f, "rad", "random turn per segment (standard deviation)"),
        real("scalp_angle_deg", &P::scalpAngleDeg, 1.0f, 180.0f, "deg", "roots cover the cap within this angle of the top"),
        real("alpha", &P::alpha, 0.0f, 1.0f, "", "the hair material's base alpha"),
        seed(&P::seed),
    };
    return table;
}

const std::vector<Field<FenceParams>>& fields(const FenceParams*)
{
    using P = FenceParams;
    static const std::vector<Field<P>> table = {
        whole("holes_x", &P::holesX, 1, 512, "holes along the width"),
        whole("holes_y", &P::holesY, 1, 512, "holes along the height"),
        positive("cell", &P::cell, "world", "centre-to-centre distance of the holes"),
        positive("bar_width", &P::barWidth, "world", "bars between holes (holes are cell - bar_width square); < cell"),
        positive("thickness", &P::thickness, "world", "depth of the lattice"),
        real("tilt_deg", &P::tiltDeg, 0.0f, 90.0f, "deg", "angle to the ground: 90 stands the lattice up, 0 lays it flat"),
        positive("elevation", &P::elevation, "world",
                 "height of the lattice's centre above the ground; the lattice may not reach into the ground"),
        positive("ground_size", &P::groundSize, "world", "side of the square ground plane"),
    };
    return table;
}

const std::vector<Field<BoxFieldParams>>& fields(const BoxFieldParams*)
{
    using P = BoxFieldParams;
    static const std::vector<Field<P>> table = {
        whole("boxes", &P::boxes, 1, 1000000, "boxes on the field"),
        positive("box_size", &P::boxSize, "world", "footprint edge of a box"),
        positive("spacing", &P::spacing, "world", "cell pitch of the grid; > box_size so that boxes never touch"),
        positive("min_height", &P::minHeight, "world", "the lowest box height"),
        positive("max_height", &P::maxHeight, "world", "the highest box height; >= min_height"),
        whole("face_divisions", &P::faceDivisions, 1, 64, "quads per box face side: 12 d² triangles per box (9: 972k triangles in all)"),
        real("margin", &P::margin, 0.0f, kFloatMax, "world", "ground beyond the field on each side"),
        seed(&P::seed),
    };
    return table;
}

bool inRange(const GeneratorParam& param, double v)
{
    if (param.whole) return v >= param.minValue && v <= param.maxValue;
    // A float compares as the float the struct holds, against its bounds as floats: a
    // bound of 0.9 takes the 0.9 a user gives. NaN and infinities fail.
    const float x = float(v), lo = float(param.minValue), hi = float(param.maxValue);
    return (param.aboveMin ? x > lo : x >= lo) && x <= hi;
}

// `text` as a number of the parameter's type (range unchecked), or nullopt. A whole
// number may be written as any integral number (8, 8.0, 1e3), as a plugin's int may,
// and as JSON Schema's "integer" takes it.
std::optional<double> parseNumber(const GeneratorParam& param, std::string_view text)
{
    const char* end = text.data() + text.size();
    if (param.whole) {
        double v = 0.0;
        const auto [ptr, ec] = std::from_chars(text.data(), end, v);
        if (ec != std::errc() || ptr != end) return std::nullopt;
        if (!(v >= 0.0 && v <= double(std::numeric_limits<uint32_t>::max())) || v != std::floor(v)) return std::nullopt;
        return v;
    }
    float v = 0.0f;
    const auto [ptr, ec] = std::from_chars(text.data(), end, v);
    if (ec != std::errc() || ptr != end) return std::nullopt;
    return double(v);
}

// Every field of `params` inside its range, else the Error that names it: what each
// generator checks first, whoever filled the struct.
template <class Params> void checkRanges(const char* generator, const Params& params)
{
    for (const Field<Params>& f : fields(&params)) {
        const double v = f.wholeMember ? double(params.*f.wholeMember) : double(params.*f.realMember);
        if (inRange(f.param, v)) continue;
        throw Error(fmt::format("{}: {} must be {}, got {}", generator, f.param.name, describeRange(f.param),
                                f.wholeMember ? fmt::format("{}", params.*f.wholeMember)
                                              : fmt::format("{}", params.*f.realMember)));
    }
}

using Settings = std::vector<std::pair<std::string, std::string>>;

struct RegisteredGenerator {
    std::string name;
    std::vector<GeneratorParam> params;
    std::function<Scene(const Settings&)> generate;
};

template <class Params> RegisteredGenerator registerGenerator(std::string name, Scene (*generate)(const Params&))
{
    std::vector<GeneratorParam> params;
    for (const Field<Params>& f : fields(static_cast<const Params*>(nullptr))) params.push_back(f.param);
    auto build = [name, generate](const Settings& settings) {
        Params values;
        for (const auto& setting : settings) {
            const GeneratorParam& param = generatorParameter(name, setting.first);  // an unknown one throws
            const std::optional<double> v = parseNumber(param, setting.second);
            if (!v) {
                throw Error(fmt::format("{}: {} must be {}, got '{}'", name, param.name, describeRange(param),
                                        core::shortText(setting.second)));
            }
            // Stored in the struct's type; its range is the generator's first check.
            for (const Field<Params>& f : fields(&values)) {
                if (f.param.name != param.name) continue;
                if (f.wholeMember) values.*f.wholeMember = uint32_t(*v);
                else values.*f.realMember = float(*v);
            }
        }
        return generate(values);
    };
    return {std::move(name), std::move(params), build};
}

const std::vector<RegisteredGenerator>& registry()
{
    static const std::vector<RegisteredGenerator> generators = {
        registerGenerator<BoxGridParams>("box-grid", generateBoxGrid),
        registerGenerator<PenumbraParams>("penumbra", generatePenumbra),
        registerGenerator<CityParams>("city", generateCity),
        registerGenerator<HairParams>("hair", generateHair),
        registerGenerator<FenceParams>("fence", generateFence),
        registerGenerator<BoxFieldParams>("box-field", generateBoxField),
    };
    return generators;
}

const RegisteredGenerator& findGenerator(const std::string& name)
{
    for (const RegisteredGenerator& g : registry()) {
        if (g.name == name) return g;
    }
    throw Error(fmt::format("unknown generator '{}'; known: {}", core::shortText(name), fmt::join(generatorNames(), ", ")));
}

} // namespace

// ---- box-grid ------------------------------------------------------------------------------

Scene generateBoxGrid(const BoxGridParams& p)
{
    checkRanges("box-grid", p);
    const ParamCheck check("box-grid");
    check.atLeast("max_height", p.maxHeight, "min_height", p.minHeight);
    // Each box 12 triangles; the sphere at most 2 segments × rings, rings = segments / 2.
    const uint64_t segments = p.sphereSegments;
    check.total("triangles", uint64_t(p.columns) * p.rows * 12 + segments * segments, kMaxGeneratedTriangles,
                "columns × rows × 12 + sphere_segments²", fmt::format("{} × {} × 12 + {}²", p.columns, p.rows, segments));

    SceneBuilder b("box-grid");
    b.place(b.addMesh(makePlane("ground"), Material{"ground", {0.75f, 0.75f, 0.72f, 1.0f}}), "ground", b.root(),
            glm::scale(glm::mat4(1.0f), glm::vec3(p.planeSize, 1.0f, p.planeSize)));

    // Each box has its own colour, hence its own mesh (a mesh is a glTF primitive, which
    // carries its material); the sphere and the ground are single meshes.
    std::mt19937 rng(p.seed);
    std::uniform_real_distribution<float> height(p.minHeight, p.maxHeight);
    std::uniform_real_distribution<float> hue(0.0f, 1.0f);
    const float x0 = -0.5f * p.spacing * float(p.columns - 1);
    const float z0 = -0.5f * p.spacing * float(p.rows - 1);
    for (uint32_t row = 0; row < p.rows; ++row) {
        for (uint32_t col = 0; col < p.columns; ++col) {
            const float h = height(rng);
            const glm::vec3 centre{x0 + p.spacing * float(col), 0.5f * h, z0 + p.spacing * float(row)};
            const float t = hue(rng);
            const std::string name = fmt::format("box_{}_{}", row, col);
            const Material material{name, {0.55f + 0.35f * t, 0.45f + 0.2f * (1.0f - t), 0.35f + 0.3f * t, 1.0f}};
            b.place(b.addMesh(makeBox(name), material), name, b.root(),
                    glm::scale(glm::translate(glm::mat4(1.0f), centre), glm::vec3(p.boxSize, h, p.boxSize)));
        }
    }
    // The sphere floats beside the grid so that its shadow falls on the ground, apart
    // from the boxes' shadows.
    const glm::vec3 sphereCentre{x0 + p.spacing * float(p.columns) + p.sphereRadius, 1.5f * p.sphereRadius, 0.0f};
    b.place(b.addMesh(makeSphere("sphere", p.sphereSegments), Material{"sphere", {0.3f, 0.45f, 0.8f, 1.0f}}), "sphere",
            b.root(), glm::scale(glm::translate(glm::mat4(1.0f), sphereCentre), glm::vec3(p.sphereRadius)));
    return b.finish();
}

// ---- penumbra ---------------------------------------------------------------------------------

Scene generatePenumbra(const PenumbraParams& p)
{
    checkRanges("penumbra", p);
    const ParamCheck check("penumbra");
    check.range("occluder_thickness", p.occluderThickness, 0.0f, 0.1f * p.occluderSize);
    if (!(p.occluderHeight > 0.5f * p.occluderThickness)) {
        check.fail("occluder_height", "> occluder_thickness / 2 (the occluder above the ground)",
                   fmt::format("{}", p.occluderHeight));
    }
    check.atLeast("ground_size", p.groundSize, "occluder_size", p.occluderSize);

    SceneBuilder b("penumbra");
    addGround(b, p.groundSize);
    const glm::vec3 centre{0.0f, p.occluderHeight, 0.0f};
    if (p.occluderThickness > 0.0f) {
        b.place(b.addMesh(makeBox("occluder"), Material{"occluder", {0.6f, 0.3f, 0.25f, 1.0f}}), "occluder", b.root(),
                translationScale(centre, {p.occluderSize, p.occluderThickness, p.occluderSize}));
    } else {
        // Zero thickness: a quad that occludes from both sides.
        Material material{"occluder", {0.6f, 0.3f, 0.25f, 1.0f}};
        material.doubleSided = true;
        b.place(b.addMesh(makePlane("occluder"), material), "occluder", b.root(),
                translationScale(centre, {p.occluderSize, 1.0f, p.occluderSize}));
    }
    return b.finish();
}

double penumbraVisibility(const PenumbraParams& p, const RectAreaLight& light, glm::vec2 receiverXz)
{
    const double h = p.occluderHeight, s = p.occluderSize;
    const double H = light.center.y;
    const double top = h + 0.5 * double(p.occluderThickness);
    if (!(H > top) || !std::isfinite(H)) {
        throw Error(fmt::format("penumbraVisibility: the light's height must be finite and above the occluder's top "
                                "({}), got {}", top, H));
    }
    if (!(light.size.x >= 0.0f && light.size.y >= 0.0f && light.size.x <= kFloatMax && light.size.y <= kFloatMax)) {
        throw Error(fmt::format("penumbraVisibility: the light's sides must be finite and >= 0, got {} x {}",
                                light.size.x, light.size.y));
    }
    const double backProjection = H / h;  // the occluder's plane, seen from the receiver, on the light's plane
    double hidden = 1.0;
    for (int axis = 0; axis < 2; ++axis) {
        const double receiver = receiverXz[axis];
        const double lightCentre = axis == 0 ? light.center.x : light.center.z;
        const double halfLight = 0.5 * double(light.size[axis]);
        hidden *= hiddenFraction(lightCentre - halfLight, lightCentre + halfLight,
                                 receiver + (-0.5 * s - receiver) * backProjection,
                                 receiver + (0.5 * s - receiver) * backProjection);
    }
    return 1.0 - hidden;
}

// ---- city ---------------------------------------------------------------------------------------

Scene generateCity(const CityParams& p)
{
    checkRanges("city", p);
    const ParamCheck check("city");
    check.range("sidewalk_width", p.sidewalkWidth, 1.5f, 0.25f * p.blockSize);
    check.atLeast("max_height", p.maxHeight, "min_height", p.minHeight);
    // Per block at most 3 tiers a lot, and per kerb slot of its 4 edges a car and a tree
    // (2 instances).
    const uint64_t slots = std::max(1u, uint32_t(p.blockSize / kParkingSlot));
    check.total("instances", uint64_t(p.blocks) * p.blocks * (3 * uint64_t(p.lotsPerSide) * p.lotsPerSide + 12 * slots),
                kMaxGeneratedInstances, "up to blocks² × (3 lots_per_side² + 12 × block_size / 6 m)",
                fmt::format("{}² × (3 × {}² + 12 × {})", p.blocks, p.lotsPerSide, slots));

    Random rng(p.seed);
    SceneBuilder b("city");
    const float pitch = p.blockSize + p.streetWidth;
    const float span = float(p.blocks) * pitch;  // blocks with a street ring around them
    addGround(b, span + p.streetWidth);
    const CityMeshes meshes = addCityMeshes(b);

    const float half = 0.5f * p.blockSize;
    const float inner = p.blockSize - 2.0f * p.sidewalkWidth;
    const float lot = inner / float(p.lotsPerSide);
    // The kerb of a block, edge by edge, counter-clockwise seen from above: start, direction.
    const std::array<std::pair<glm::vec3, glm::vec3>, 4> edges = {{{{-half, 0, -half}, {1, 0, 0}},
                                                                   {{half, 0, -half}, {0, 0, 1}},
                                                                   {{half, 0, half}, {-1, 0, 0}},
                                                                   {{-half, 0, half}, {0, 0, -1}}}};
    for (uint32_t i = 0; i < p.blocks; ++i) {
        for (uint32_t j = 0; j < p.blocks; ++j) {
            const glm::vec3 centre{-0.5f * span + (float(i) + 0.5f) * pitch, 0.0f, -0.5f * span + (float(j) + 0.5f) * pitch};
            const uint32_t block = b.addNode(fmt::format("block_{}_{}", i, j), b.root(), translation(centre));
            for (uint32_t lx = 0; lx < p.lotsPerSide; ++lx) {
                for (uint32_t lz = 0; lz < p.lotsPerSide; ++lz) {
                    const glm::vec3 at{-0.5f * inner + (float(lx) + 0.5f) * lot, 0.0f, -0.5f * inner + (float(lz) + 0.5f) * lot};
                    const uint32_t building = b.addNode(fmt::format("building_{}_{}", lx, lz), block, translation(at));
                    addBuilding(b, p, meshes, rng, building, lot);
                }
            }
            for (const auto& [start, along] : edges) addKerbside(b, p, meshes, rng, block, start, along);
        }
    }
    return b.finish();
}

// ---- box-field ------------------------------------------------------------------------------------

Scene generateBoxField(const BoxFieldParams& p)
{
    checkRanges("box-field", p);
    const ParamCheck check("box-field");
    if (!(p.spacing > p.boxSize)) {
        check.fail("spacing", fmt::format("> box_size ({}) so that boxes never touch", p.boxSize), fmt::format("{}", p.spacing));
    }
    check.atLeast("max_height", p.maxHeight, "min_height", p.minHeight);
    const uint64_t d = p.faceDivisions;
    check.total("triangles", uint64_t(p.boxes) * 12 * d * d, kMaxGeneratedTriangles, "boxes × 12 × face_divisions²",
                fmt::format("{} × 12 × {}²", p.boxes, d));

    Random rng(p.seed);
    SceneBuilder b("box-field");
    const auto perSide = static_cast<uint32_t>(std::ceil(std::sqrt(double(p.boxes))));
    const float span = p.spacing * float(perSide);
    addGround(b, span + 2.0f * p.margin);
    // Each box keeps a clearance of (spacing - box_size) / 2 split between its jitter and
    // its neighbour's: it moves at most a quarter of the gap either way.
    const float jitter = 0.25f * (p.spacing - p.boxSize);
    const Mesh box = makeDividedBox("box", p.faceDivisions);
    for (uint32_t i = 0; i < p.boxes; ++i) {
        const uint32_t row = i / perSide, col = i % perSide;
        const float h = rng.uniform(p.minHeight, p.maxHeight);
        const glm::vec3 centre{-0.5f * span + p.spacing * (float(col) + 0.5f) + rng.uniform(-jitter, jitter), 0.5f * h,
                               -0.5f * span + p.spacing * (float(row) + 0.5f) + rng.uniform(-jitter, jitter)};
        const float t = rng.uniform();
        const std::string name = fmt::format("box_{}", i);
        Mesh mesh = box;
        mesh.name = name;
        const Material material{name, {0.5f + 0.4f * t, 0.55f - 0.15f * t, 0.4f + 0.2f * (1.0f - t), 1.0f}};
        b.place(b.addMesh(std::move(mesh), material), name, b.root(), translationScale(centre, {p.boxSize, h, p.boxSize}));
    }
    return b.finish();
}

// ---- hair -----------------------------------------------------------------------------------------

Scene generateHair(const HairParams& p)
{
    checkRanges("hair", p);

    Random rng(p.seed);
    SceneBuilder b("hair");
    // Every point of a strand lies within its length of its root, so the hair stays
    // above the ground.
    const float reach = p.headRadius + p.strandLength * (1.0f + p.lengthJitter);
    addGround(b, 8.0f * reach);
    const uint32_t head = b.addNode("head", b.root(), translation({0.0f, 1.05f * reach, 0.0f}));
    b.place(b.addMesh(makeSphere("skull", 64), Material{"skin", {0.8f, 0.6f, 0.5f, 1.0f}}), "skull", head,
            glm::scale(glm::mat4(1.0f), glm::vec3(p.headRadius)));
    Material hair{"hair", {0.35f, 0.22f, 0.12f, p.alpha}};
    hair.alphaMode = AlphaMode::Blend;
    hair.doubleSided = true;
    b.place(b.addMesh(makeHair(p, rng), hair), "strands", head, glm::mat4(1.0f));
    return b.finish();
}

// ---- fence -----------------------------------------------------------------------------------------

Scene generateFence(const FenceParams& p)
{
    checkRanges("fence", p);
    const ParamCheck check("fence");
    if (!(p.barWidth < p.cell)) check.fail("bar_width", fmt::format("< cell ({})", p.cell), fmt::format("{}", p.barWidth));
    const float tilt = glm::radians(p.tiltDeg);
    const float height = float(p.holesY) * p.cell + p.barWidth;
    const float lowest = 0.5f * height * std::sin(tilt) + 0.5f * p.thickness * std::cos(tilt);
    if (!(p.elevation > lowest && p.elevation <= kFloatMax)) {
        check.fail("elevation", fmt::format("> {} (the lattice above the ground)", lowest), fmt::format("{}", p.elevation));
    }

    SceneBuilder b("fence");
    addGround(b, p.groundSize);
    // The lattice is built upright (tilt 90): turning it about x lays it down.
    const glm::mat4 local = glm::rotate(translation({0.0f, p.elevation, 0.0f}), tilt - glm::half_pi<float>(), glm::vec3(1, 0, 0));
    b.place(b.addMesh(makeLattice(p), Material{"lattice", {0.25f, 0.25f, 0.27f, 1.0f}}), "lattice", b.root(), local);
    return b.finish();
}

// ---- scale -----------------------------------------------------------------------------------------

Scene& scaleScene(Scene& scene, float factor)
{
    if (!(factor > 0.0f && factor <= kFloatMax)) {
        throw Error(fmt::format("scaleScene: the scale factor must be a finite number > 0, got {}", factor));
    }
    const glm::mat4 scale = glm::scale(glm::mat4(1.0f), glm::vec3(factor));
    for (uint32_t n = 0; n < scene.graph.size(); ++n) {
        if (scene.graph.node(n).parent == kNoParent) scene.graph.setLocal(n, scale * scene.graph.local(n));
    }
    // An animated root node is posed from its parts (T · R · S): a uniform scale s of it is
    // (s T) · R · (s S), so its rest pose and its translation and scale keys (tangents too)
    // take the factor.
    auto isRoot = [&](uint32_t node) { return scene.graph.node(node).parent == kNoParent; };
    for (NodeAnimation& animation : scene.animations) {
        for (NodeRestPose& rest : animation.rest) {
            if (!isRoot(rest.node)) continue;
            rest.translation *= factor;
            rest.scale *= factor;
        }
        for (NodeChannel& channel : animation.channels) {
            if (!isRoot(channel.node) || channel.path == ChannelPath::Rotation) continue;
            for (float& v : channel.values) v *= factor;
        }
    }
    scene.updateTransforms();
    return scene;
}

// ---- by name ---------------------------------------------------------------------------------------

std::string describeRange(const GeneratorParam& param)
{
    const bool bounded = param.maxValue < (param.whole ? double(std::numeric_limits<uint32_t>::max()) : double(kFloatMax));
    if (param.whole) return fmt::format("a whole number in [{}, {}]", param.minValue, param.maxValue);
    if (!bounded) return fmt::format("a finite number {} {}", param.aboveMin ? ">" : ">=", param.minValue);
    return fmt::format("a number in {}{}, {}]", param.aboveMin ? "(" : "[", param.minValue, param.maxValue);
}

std::optional<double> parseGeneratorValue(const GeneratorParam& param, std::string_view text)
{
    const std::optional<double> v = parseNumber(param, text);
    if (!v || !inRange(param, *v)) return std::nullopt;
    return v;
}

std::vector<std::string> generatorNames()
{
    std::vector<std::string> names;
    for (const RegisteredGenerator& g : registry()) names.push_back(g.name);
    return names;
}

const std::vector<GeneratorParam>& generatorParameters(const std::string& generator)
{
    return findGenerator(generator).params;
}

const GeneratorParam& generatorParameter(const std::string& generator, std::string_view name)
{
    const std::vector<GeneratorParam>& params = generatorParameters(generator);
    std::vector<std::string> names;
    for (const GeneratorParam& p : params) {
        if (p.name == name) return p;
        names.push_back(p.name);
    }
    const std::string best = core::closestMatch(name, names);
    throw Error(fmt::format("{}: unknown parameter '{}'{} (known: {})", generator, core::shortText(name),
                            best.empty() ? "" : fmt::format("; did you mean '{}'?", best), fmt::join(names, ", ")));
}

Scene generateScene(const std::string& generator, const Settings& settings)
{
    return findGenerator(generator).generate(settings);
}

} // namespace penumbra::scene
