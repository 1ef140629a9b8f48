// Procedural scenes: determinism, counts, well-formed meshes, parameter tables and checks
// (and the config schema's copy of the tables), scale, and the penumbra scene's closed-form
// visibility against ray casting.
#include "ErrorText.h"
#include "RayCast.h"
#include "TestPaths.h"  // support/: the build tree's paths

#include "penumbra/core/Error.h"
#include "penumbra/scene/Generators.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <optional>
#include <tuple>

using namespace penumbra;
using namespace penumbra::scene;
using penumbra::test::errorOf;

namespace {

// Byte-for-byte equality of everything a generator decides.
bool sameScene(const Scene& a, const Scene& b)
{
    if (a.meshes.size() != b.meshes.size() || a.materials.size() != b.materials.size() ||
        a.graph.size() != b.graph.size() || a.instances.size() != b.instances.size()) {
        return false;
    }
    for (size_t i = 0; i < a.meshes.size(); ++i) {
        const Mesh &x = a.meshes[i], &y = b.meshes[i];
        if (x.name != y.name || x.material != y.material || x.indices != y.indices || x.vertices.size() != y.vertices.size() ||
            std::memcmp(x.vertices.data(), y.vertices.data(), x.vertices.size() * sizeof(Vertex)) != 0) {
            return false;
        }
    }
    for (size_t i = 0; i < a.materials.size(); ++i) {
        if (a.materials[i].name != b.materials[i].name || a.materials[i].baseColor != b.materials[i].baseColor) return false;
    }
    for (uint32_t n = 0; n < a.graph.size(); ++n) {
        const Node &x = a.graph.node(n), &y = b.graph.node(n);
        if (x.name != y.name || x.parent != y.parent || x.local != y.local) return false;
    }
    for (size_t i = 0; i < a.instances.size(); ++i) {
        if (a.instances[i].mesh != b.instances[i].mesh || a.instances[i].node != b.instances[i].node) return false;
    }
    return true;
}

// Every generator at its defaults, plus the variants that build different geometry.
std::vector<std::pair<std::string, Scene>> everyGenerator()
{
    std::vector<std::pair<std::string, Scene>> scenes;
    for (const std::string& name : generatorNames()) scenes.emplace_back(name, generateScene(name, {}));
    scenes.emplace_back("penumbra thickness 0", generateScene("penumbra", {{"occluder_thickness", "0"}}));
    scenes.emplace_back("fence tilt 0", generateScene("fence", {{"tilt_deg", "0"}, {"elevation", "0.5"}}));
    scenes.emplace_back("fence tilt 30", generateScene("fence", {{"tilt_deg", "30"}}));
    scenes.emplace_back("box-field divided", generateScene("box-field", {{"boxes", "20"}, {"face_divisions", "3"}}));
    return scenes;
}

const Mesh& meshNamed(const Scene& s, const std::string& name)
{
    for (const Mesh& m : s.meshes) {
        if (m.name == name) return m;
    }
    throw std::runtime_error("no mesh " + name);
}

const Material& materialOf(const Scene& s, const std::string& mesh) { return s.materials.at(meshNamed(s, mesh).material); }

} // namespace

TEST(Generators, ListedByName)
{
    EXPECT_EQ(generatorNames(), (std::vector<std::string>{"box-grid", "penumbra", "city", "hair", "fence", "box-field"}));
    EXPECT_TRUE(sameScene(generateScene("box-grid", {}), generateBoxGrid({})));
    EXPECT_TRUE(sameScene(generateScene("fence", {}), generateFence({})));
    CityParams city;
    city.blocks = 3;
    EXPECT_TRUE(sameScene(generateScene("city", {{"blocks", "3"}}), generateCity(city)));
    const std::vector<GeneratorParam>& params = generatorParameters("city");
    ASSERT_FALSE(params.empty());
    EXPECT_EQ(params[0].name, "blocks");
    EXPECT_EQ(params[0].defaultValue, 8.0);
    EXPECT_TRUE(params[0].whole);
}

// The JSON schema's properties of one generator parameter, as the table gives them.
nlohmann::ordered_json schemaProperty(const GeneratorParam& p)
{
    nlohmann::ordered_json j;
    j["$ref"] = p.whole ? "#/$defs/wholeNumber" : "#/$defs/realNumber";
    // Whole numbers as JSON integers, as the schema writes them.
    const auto number = [&](double v) { return p.whole ? nlohmann::ordered_json(uint64_t(v)) : nlohmann::ordered_json(v); };
    j[p.aboveMin ? "exclusiveMinimum" : "minimum"] = number(p.minValue);
    if (p.whole || p.maxValue < double(std::numeric_limits<float>::max())) j["maximum"] = number(p.maxValue);
    j["default"] = number(p.defaultValue);
    j["description"] = p.unit.empty() ? p.doc : p.doc + " (unit: " + p.unit + ")";
    return j;
}

// config/schema/penumbra-config.schema.json holds every generator's parameter table for
// editors: the same names in the same order, types, ranges, defaults and docs. On a
// difference the test prints the properties to paste there.
TEST(Generators, ConfigSchemaHoldsEveryParameterTable)
{
    std::ifstream in(penumbra::test::sourceDir() / "config/schema/penumbra-config.schema.json");
    const nlohmann::ordered_json schema = nlohmann::ordered_json::parse(in);
    std::vector<std::string> names = generatorNames();
    names.push_back("null");
    std::vector<std::string> schemaNames;
    for (const nlohmann::ordered_json& name : schema["$defs"]["scene"]["properties"]["generator"]["enum"]) {
        schemaNames.push_back(name.is_string() ? name.get<std::string>() : name.dump());
    }
    EXPECT_EQ(schemaNames, names);
    for (const std::string& name : generatorNames()) {
        SCOPED_TRACE(name);
        nlohmann::ordered_json expected = nlohmann::ordered_json::object();
        for (const GeneratorParam& p : generatorParameters(name)) expected[p.name] = schemaProperty(p);
        EXPECT_EQ(schema["$defs"]["generatorParams"][name]["properties"], expected) << "expected:\n" << expected.dump();
    }
}

// Each kind of parameter refuses a value outside its range, and a value not of its
// type, naming the generator, the parameter and what it must be.
TEST(Generators, RangeErrorsSayWhatEachTypeMustBe)
{
    const std::vector<std::tuple<std::string, std::string, std::string, std::string>> cases = {
        {"city", "blocks", "129", "city: blocks must be a whole number in [1, 128], got 129"},
        {"city", "blocks", "2.5", "city: blocks must be a whole number in [1, 128], got '2.5'"},
        {"city", "blocks", "-1", "city: blocks must be a whole number in [1, 128], got '-1'"},
        {"hair", "alpha", "1.5", "hair: alpha must be a number in [0, 1], got 1.5"},
        {"hair", "alpha", "x", "hair: alpha must be a number in [0, 1], got 'x'"},
        {"fence", "cell", "0", "fence: cell must be a finite number > 0, got 0"},
        {"fence", "cell", "inf", "fence: cell must be a finite number > 0, got inf"},
        {"box-field", "margin", "-0.5", "box-field: margin must be a finite number >= 0, got -0.5"},
        {"city", "max_height", "20000", "city: max_height must be a number in (0, 10000], got 20000"},
    };
    for (const auto& [generator, key, value, expected] : cases) {
        SCOPED_TRACE(generator + " " + key + "=" + value);
        EXPECT_EQ(errorOf([&] { generateScene(generator, {{key, value}}); }), expected);
        const std::optional<double> parsed = parseGeneratorValue(generatorParameter(generator, key), value);
        EXPECT_FALSE(parsed.has_value());
    }
    // The ends of each range are in it; a float bound takes the decimal a user writes.
    EXPECT_EQ(parseGeneratorValue(generatorParameter("city", "blocks"), "128"), 128.0);
    EXPECT_EQ(parseGeneratorValue(generatorParameter("city", "blocks"), "8.0"), 8.0) << "an integral number is whole";
    EXPECT_EQ(parseGeneratorValue(generatorParameter("hair", "length_jitter"), "0.9"), double(0.9f));
    EXPECT_EQ(parseGeneratorValue(generatorParameter("box-field", "margin"), "0"), 0.0);
    // A struct filled in code is checked against the same table.
    HairParams hair;
    hair.segments = 65;
    EXPECT_EQ(errorOf([&] { generateHair(hair); }), "hair: segments must be a whole number in [1, 64], got 65");
}

TEST(Generators, AnUnknownParameterIsNamedWithTheClosestKnownOne)
{
    EXPECT_EQ(errorOf([] { generateScene("fence", {{"hole_x", "4"}}); }),
              "fence: unknown parameter 'hole_x'; did you mean 'holes_x'? (known: holes_x, holes_y, cell, bar_width, "
              "thickness, tilt_deg, elevation, ground_size)");
    EXPECT_EQ(errorOf([] { generatorParameter("penumbra", "light"); }),
              "penumbra: unknown parameter 'light' (known: occluder_size, occluder_thickness, occluder_height, ground_size)");
}

TEST(Generators, DeterministicBySeed)
{
    for (const char* name : {"box-grid", "city", "hair", "box-field"}) {
        SCOPED_TRACE(name);
        const Scene a = generateScene(name, {{"seed", "7"}}), b = generateScene(name, {{"seed", "7"}});
        const Scene c = generateScene(name, {{"seed", "8"}});
        EXPECT_TRUE(sameScene(a, b));
        EXPECT_FALSE(sameScene(a, c));
    }
}

TEST(Generators, EveryMeshIsWellFormed)
{
    for (const auto& [name, scene] : everyGenerator()) {
        SCOPED_TRACE(name);
        ASSERT_FALSE(scene.instances.empty());
        for (const Mesh& mesh : scene.meshes) {
            SCOPED_TRACE(mesh.name);
            ASSERT_FALSE(mesh.indices.empty());
            ASSERT_EQ(mesh.indices.size() % 3, 0u);
            ASSERT_LT(mesh.material, scene.materials.size());
            for (const Vertex& v : mesh.vertices) {
                ASSERT_TRUE(std::isfinite(v.position.x) && std::isfinite(v.position.y) && std::isfinite(v.position.z));
                ASSERT_NEAR(glm::length(v.normal), 1.0f, 1e-4f);
            }
            // Non-degenerate (area well above float noise for the mesh's size), and
            // wound counter-clockwise around the normals.
            const float size = glm::length(mesh.bounds.extent());
            for (size_t t = 0; t < mesh.indices.size(); t += 3) {
                const uint32_t i0 = mesh.indices[t], i1 = mesh.indices[t + 1], i2 = mesh.indices[t + 2];
                ASSERT_LT(std::max({i0, i1, i2}), mesh.vertices.size());
                const Vertex &a = mesh.vertices[i0], &b = mesh.vertices[i1], &c = mesh.vertices[i2];
                const glm::vec3 cross = glm::cross(b.position - a.position, c.position - a.position);
                ASSERT_GT(0.5f * glm::length(cross), 1e-9f * size * size) << "triangle " << t / 3;
                ASSERT_GT(glm::dot(cross, a.normal + b.normal + c.normal), 0.0f) << "triangle " << t / 3;
            }
        }
    }
}

TEST(Generators, BadParametersAreNamed)
{
    const std::vector<std::tuple<std::string, std::string, std::string>> cases = {
        {"box-grid", "max_height", "0.1"},       {"box-grid", "columns", "0"},
        {"penumbra", "occluder_thickness", "0.5"}, {"penumbra", "occluder_size", "-1"},
        {"penumbra", "ground_size", "0.5"},       {"city", "blocks", "0"},
        {"city", "block_size", "-5"},            {"city", "car_density", "1.5"},
        {"city", "min_height", "nan"},           {"hair", "strands", "0"},
        {"hair", "alpha", "1.5"},                {"hair", "strand_length", "inf"},
        {"fence", "bar_width", "0.2"},           {"fence", "elevation", "0.1"},
        {"fence", "tilt_deg", "91"},            {"box-field", "boxes", "0"},
        {"box-field", "spacing", "0.5"},         {"box-field", "max_height", "0.2"},
        {"box-field", "face_divisions", "0"},    {"box-field", "margin", "-1"},
        {"box-field", "box_size", "nan"},
    };
    for (const auto& [generator, key, value] : cases) {
        const std::string message = errorOf([&] { generateScene(generator, {{key, value}}); });
        EXPECT_NE(message.find(generator + ": " + key + " must be"), std::string::npos) << message;
        EXPECT_NE(message.find("got " + value), std::string::npos) << message;
    }
    const std::string unknown = errorOf([] { generateScene("city", {{"blokcs", "4"}}); });
    EXPECT_NE(unknown.find("city: unknown parameter 'blokcs'; did you mean 'blocks'? (known: blocks, block_size,"),
              std::string::npos)
        << unknown;
    const std::string unparsable = errorOf([] { generateScene("city", {{"blocks", "4x"}}); });
    EXPECT_NE(unparsable.find("city: blocks must be a whole number"), std::string::npos) << unparsable;
    EXPECT_NE(unparsable.find("'4x'"), std::string::npos) << unparsable;
    const std::string generator = errorOf([] { generateScene("castle", {}); });
    EXPECT_NE(generator.find("unknown generator 'castle'; known: box-grid, penumbra, city, hair, fence, box-field"), std::string::npos)
        << generator;
}

TEST(Generators, TotalsTheParametersMultiplyToAreCheckedBeforeBuilding)
{
    // Each parameter within its range, their product not: refused at once (building it
    // would take 49 billion triangles), naming the parameters, the total and the limit.
    const std::string field = errorOf([] { generateScene("box-field", {{"boxes", "1000000"}, {"face_divisions", "64"}}); });
    EXPECT_NE(field.find("box-field: boxes × 12 × face_divisions² = 1000000 × 12 × 64² = 49152000000 triangles; a "
                         "generated scene holds at most 32000000 triangles"),
              std::string::npos)
        << field;
    const std::string city = errorOf([] { generateScene("city", {{"blocks", "128"}, {"lots_per_side", "16"}}); });
    EXPECT_NE(city.find("city: up to blocks² × (3 lots_per_side² + 12 × block_size / 6 m) = 128² × (3 × 16² + 12 × 10)"),
              std::string::npos)
        << city;
    EXPECT_NE(city.find("instances; a generated scene holds at most 4000000 instances"), std::string::npos) << city;
    // The totals bound what is built: exactly for box-field (and its ground's 2), from
    // above for box-grid's sphere and the city's instances.
    const auto triangles = [](const Scene& scene) {
        uint64_t n = 0;
        for (const Mesh& mesh : scene.meshes) n += mesh.indices.size() / 3;
        return n;
    };
    EXPECT_EQ(triangles(generateScene("box-field", {{"boxes", "20"}, {"face_divisions", "3"}})), 20u * 12 * 9 + 2);
    EXPECT_LE(triangles(generateScene("box-grid", {{"sphere_segments", "40"}})), 5u * 5 * 12 + 40 * 40 + 2);
    EXPECT_LE(generateScene("city", {{"blocks", "2"}, {"car_density", "1"}, {"tree_chance", "1"}, {"setback_chance", "1"}})
                  .instances.size(),
              2u * 2 * (3 * 3 * 3 + 12 * 10) + 1);
}

TEST(ScaleScene, ScalesBoundsExactly)
{
    for (const auto& [name, scene] : everyGenerator()) {
        SCOPED_TRACE(name);
        const Aabb before = scene.bounds();
        const float size = std::max(glm::length(before.min), glm::length(before.max));
        for (const float factor : {8.0f, 0.25f, 1e-3f, 1e5f}) {
            SCOPED_TRACE(factor);
            Scene scaled = scene;
            const Aabb after = scaleScene(scaled, factor).bounds();
            // Powers of two scale floats exactly; the others within a few roundings.
            const bool exact = factor == 8.0f || factor == 0.25f;
            const float tolerance = exact ? 0.0f : 1e-6f * size * factor;
            for (int a = 0; a < 3; ++a) {
                EXPECT_NEAR(after.min[a], before.min[a] * factor, tolerance);
                EXPECT_NEAR(after.max[a], before.max[a] * factor, tolerance);
            }
            for (size_t m = 0; m < scene.meshes.size(); ++m) {  // meshes untouched
                EXPECT_EQ(std::memcmp(scaled.meshes[m].vertices.data(), scene.meshes[m].vertices.data(),
                                      scene.meshes[m].vertices.size() * sizeof(Vertex)), 0);
            }
        }
    }
}

TEST(ScaleScene, RejectsBadFactors)
{
    Scene scene = generatePenumbra({});
    for (const float factor : {0.0f, -2.0f, NAN, INFINITY}) {
        const std::string message = errorOf([&] { scaleScene(scene, factor); });
        EXPECT_NE(message.find("scale factor must be a finite number > 0, got "), std::string::npos) << message;
    }
    EXPECT_NEAR(scene.bounds().max.x, 10.0f, 1e-6f);  // unchanged
}

TEST(City, ScalesPastAMillionTrianglesAndTenThousandInstances)
{
    // Counts only: the big parameter set of the README.
    const Scene city = generateScene("city", {{"blocks", "16"}});
    EXPECT_GE(city.triangleCount(), 1'000'000u);
    EXPECT_GE(city.instances.size(), 10'000u);
    // Instances share a few small meshes, so memory stays modest.
    EXPECT_LE(city.meshes.size(), 20u);
    size_t vertices = 0;
    for (const Mesh& m : city.meshes) vertices += m.vertices.size();
    EXPECT_LT(vertices, 5'000u);
}

TEST(City, BuildingsStayInTheirBlocksAndCarsOnTheStreets)
{
    CityParams p;
    p.blocks = 3;
    const Scene city = generateCity(p);
    const float pitch = p.blockSize + p.streetWidth, span = 3 * pitch;
    // The block under an x or z coordinate: its index, and whether it lies inside the block.
    auto inBlock = [&](float v) {
        const float local = std::fmod(v + 0.5f * span, pitch) - 0.5f * p.streetWidth;
        return local > -1e-3f && local < p.blockSize + 1e-3f;
    };
    size_t tiers = 0, cars = 0;
    for (const Instance& inst : city.instances) {
        const std::string& mesh = city.meshes[inst.mesh].name;
        const Aabb& box = inst.worldBounds;
        if (mesh.rfind("facade_", 0) == 0) {
            ++tiers;
            EXPECT_TRUE(inBlock(box.min.x) && inBlock(box.max.x) && inBlock(box.min.z) && inBlock(box.max.z));
            EXPECT_GE(box.min.y, 0.0f);
            EXPECT_LE(box.max.y, p.maxHeight + 1e-3f);
        } else if (mesh.rfind("car_", 0) == 0) {
            ++cars;
            const glm::vec3 c = box.center();
            EXPECT_FALSE(inBlock(c.x) && inBlock(c.z)) << c.x << ", " << c.z;
        }
    }
    EXPECT_GE(tiers, 9u * 9u);
    EXPECT_GT(cars, 0u);
}

TEST(Hair, TenThousandBlendedStrandsOnAnOpaqueHead)
{
    const HairParams p;
    const Scene hair = generateHair(p);
    const Mesh& strands = meshNamed(hair, "hair");
    EXPECT_EQ(strands.vertices.size(), size_t(p.strands) * 2 * (p.segments + 1));
    EXPECT_EQ(strands.indices.size() / 3, size_t(p.strands) * 2 * p.segments);
    EXPECT_GE(p.strands, 10'000u);
    const Material& material = materialOf(hair, "hair");
    EXPECT_EQ(material.alphaMode, AlphaMode::Blend);
    EXPECT_FLOAT_EQ(material.baseColor.a, 0.3f);
    EXPECT_TRUE(material.doubleSided);
    EXPECT_EQ(materialOf(hair, "skull").alphaMode, AlphaMode::Opaque);
    // Strands never enter the head (the mesh is relative to its centre) and hang above
    // the ground.
    float nearest = INFINITY;
    for (const Vertex& v : strands.vertices) nearest = std::min(nearest, glm::length(v.position));
    EXPECT_GE(nearest, p.headRadius);
    for (const Instance& inst : hair.instances) {
        if (hair.meshes[inst.mesh].name == "hair") {
            EXPECT_GT(inst.worldBounds.min.y, 0.0f);
        }
    }
}

TEST(Fence, HolesLetLightThroughAndBarsBlockIt)
{
    FenceParams p;
    p.holesX = 4;
    p.holesY = 3;
    const Scene fence = generateFence(p);
    const test::RayCaster rays(fence);
    // Upright and centred on x = 0 at height `elevation`, thickness along z.
    const double width = p.holesX * p.cell + p.barWidth, height = p.holesY * p.cell + p.barWidth;
    auto through = [&](double x, double y) {
        return !rays.segmentBlocked({x, y, -1.0}, {x, y, 1.0});
    };
    const double left = -0.5 * width, bottom = p.elevation - 0.5 * height;
    for (uint32_t i = 0; i < p.holesX; ++i) {
        // Bar i spans [i cell, i cell + bar] from the left edge, hole i the rest of the cell.
        const double barX = left + i * p.cell + 0.5 * p.barWidth;
        const double holeX = left + i * p.cell + 0.5 * (p.barWidth + p.cell);
        for (uint32_t j = 0; j < p.holesY; ++j) {
            const double holeY = bottom + j * p.cell + 0.5 * (p.barWidth + p.cell);
            EXPECT_TRUE(through(holeX, holeY)) << i << ", " << j;
            EXPECT_FALSE(through(barX, holeY)) << "bar " << i << ", " << j;
        }
    }
    EXPECT_TRUE(through(left - 0.01, p.elevation));  // beside the lattice
    // Laid flat it is only as tall as it is thick.
    p.tiltDeg = 0;
    p.elevation = 0.5f;
    const Scene flat = generateFence(p);
    EXPECT_NEAR(flat.instances.back().worldBounds.extent().y, p.thickness, 1e-5f);
}

// ---- the penumbra scene's closed form ---------------------------------------------------------

namespace {

double visibility(const PenumbraParams& p, const RectAreaLight& light, double x, double z)
{
    return penumbraVisibility(p, light, glm::vec2(float(x), float(z)));
}

} // namespace

// The osgShadow benchmark's scene: 1,000 boxes in 1,001 meshes, 12k triangles; face
// divisions take the same field to the 972k-triangle variant.
TEST(BoxField, TheBenchmarkSceneAndItsMillionTriangleVariant)
{
    const Scene field = generateScene("box-field", {});
    EXPECT_EQ(field.meshes.size(), 1001u);
    EXPECT_EQ(field.instances.size(), 1001u);
    EXPECT_EQ(field.triangleCount(), 12002u);
    const Scene dense = generateScene("box-field", {{"face_divisions", "9"}});
    EXPECT_EQ(dense.meshes.size(), 1001u);
    EXPECT_EQ(dense.triangleCount(), 972002u);
    // Same seed, same boxes: only the tessellation differs.
    ASSERT_EQ(dense.instances.size(), field.instances.size());
    for (size_t i = 0; i < field.instances.size(); ++i) {
        const Aabb &a = field.instances[i].worldBounds, &b = dense.instances[i].worldBounds;
        EXPECT_LT(glm::length(a.min - b.min) + glm::length(a.max - b.max), 1e-4f) << i;
    }
}

TEST(BoxField, BoxesStandOnTheGroundInsideItApartAndInTheirHeightRange)
{
    BoxFieldParams p;
    p.boxes = 50;  // not a square: the last row is partly filled
    p.minHeight = 1.0f;
    p.maxHeight = 3.0f;
    const Scene field = generateBoxField(p);
    ASSERT_EQ(field.instances.size(), 51u);
    const Aabb& ground = field.instances[0].worldBounds;
    // 8 cells per side of 2.5, plus the margin both ways.
    EXPECT_NEAR(ground.max.x - ground.min.x, 8 * p.spacing + 2 * p.margin, 1e-4f);
    std::vector<Aabb> boxes;
    float lowest = 1e9f, highest = 0.0f;
    for (size_t i = 1; i < field.instances.size(); ++i) {
        const Aabb& box = field.instances[i].worldBounds;
        EXPECT_NEAR(box.min.y, 0.0f, 1e-5f) << i;
        EXPECT_NEAR(box.max.x - box.min.x, p.boxSize, 1e-5f) << i;
        EXPECT_NEAR(box.max.z - box.min.z, p.boxSize, 1e-5f) << i;
        lowest = std::min(lowest, box.max.y);
        highest = std::max(highest, box.max.y);
        EXPECT_GE(box.max.y, p.minHeight - 1e-5f) << i;
        EXPECT_LE(box.max.y, p.maxHeight + 1e-5f) << i;
        // Inside the ground, at least the margin from its edge.
        EXPECT_GE(box.min.x, ground.min.x + p.margin - 1e-4f) << i;
        EXPECT_LE(box.max.z, ground.max.z - p.margin + 1e-4f) << i;
        for (const Aabb& other : boxes) {
            const bool apart = box.min.x >= other.max.x || other.min.x >= box.max.x || box.min.z >= other.max.z ||
                               other.min.z >= box.max.z;
            EXPECT_TRUE(apart) << i;
        }
        boxes.push_back(box);
    }
    // Random heights spread over the range.
    EXPECT_LT(lowest, 1.5f);
    EXPECT_GT(highest, 2.5f);
}

TEST(PenumbraVisibility, FullyLitFarAway)
{
    const PenumbraParams p;
    const RectAreaLight light;
    EXPECT_EQ(visibility(p, light, 5.0, 0.0), 1.0);
    EXPECT_EQ(visibility(p, light, 0.0, -5.0), 1.0);
    EXPECT_EQ(visibility(p, light, 3.0, 3.0), 1.0);
}

TEST(PenumbraVisibility, UmbraUnderTheCentreOnlyForALightSmallerThanTheOccluder)
{
    const PenumbraParams p;  // 1 x 1 at height 1
    RectAreaLight light;     // 0.5 x 0.5 at height 4
    EXPECT_EQ(visibility(p, light, 0.0, 0.0), 0.0);
    EXPECT_EQ(visibility(p, light, 0.1, -0.1), 0.0);
    // A light wider than the occluder's back-projection (s H / h = 4) is never hidden.
    light.size = {5.0f, 5.0f};
    EXPECT_GT(visibility(p, light, 0.0, 0.0), 0.0);
}

TEST(PenumbraVisibility, Symmetric)
{
    const PenumbraParams p;
    const RectAreaLight light;  // square, centred above the occluder
    for (double x = 0.0; x < 1.5; x += 0.07) {
        for (double z = 0.0; z < 1.5; z += 0.11) {
            const double v = visibility(p, light, x, z);
            EXPECT_NEAR(visibility(p, light, -x, z), v, 1e-6);
            EXPECT_NEAR(visibility(p, light, x, -z), v, 1e-6);
            EXPECT_NEAR(visibility(p, light, z, x), v, 1e-6);
        }
    }
}

TEST(PenumbraVisibility, MonotoneAlongLinesLeavingTheUmbra)
{
    const PenumbraParams p;
    const RectAreaLight light;
    for (const glm::dvec2 direction : {glm::dvec2(1, 0), glm::dvec2(0, -1), glm::normalize(glm::dvec2(1, 0.6))}) {
        double previous = visibility(p, light, 0.0, 0.0);
        EXPECT_EQ(previous, 0.0);
        for (int i = 1; i <= 400; ++i) {
            const glm::dvec2 at = direction * (i * 0.005);
            const double v = visibility(p, light, at.x, at.y);
            EXPECT_GE(v, previous - 1e-12) << i;
            previous = v;
        }
        EXPECT_EQ(previous, 1.0);
    }
}

TEST(PenumbraVisibility, PointLightCastsAHardEdge)
{
    const PenumbraParams p;
    RectAreaLight light;
    light.size = {0.0f, 0.0f};
    // The shadow of the edge s/2 at height h from height H.
    const double edge = 0.5 * p.occluderSize * light.center.y / (light.center.y - p.occluderHeight);
    for (double x = 0.0; x < 2.0; x += 0.01) {
        const double v = visibility(p, light, x, 0.0);
        EXPECT_TRUE(v == 0.0 || v == 1.0) << x;
    }
    EXPECT_EQ(visibility(p, light, edge - 1e-4, 0.0), 0.0);
    EXPECT_EQ(visibility(p, light, edge + 1e-4, 0.0), 1.0);
}

TEST(PenumbraVisibility, PenumbraWidthIsTheThesisFormula)
{
    const PenumbraParams p;
    RectAreaLight light;
    light.size = {0.8f, 0.01f};  // wide along x, nearly a line along z
    const double H = light.center.y, h = p.occluderHeight, w = light.size.x;
    // First x with any light and first x with all of it, on the line z = 0.
    double start = -1, end = -1;
    for (double x = 0.0; x < 3.0; x += 1e-4) {
        const double v = visibility(p, light, x, 0.0);
        if (start < 0 && v > 0.0) start = x;
        if (end < 0 && v >= 1.0) end = x;
    }
    EXPECT_NEAR(end - start, w * h / (H - h), 2e-4);
    // Half lit where the back-projected edge crosses the light's centre: under the
    // point-light shadow edge.
    EXPECT_NEAR(visibility(p, light, 0.5 * p.occluderSize * H / (H - h), 0.0), 0.5, 1e-6);
}

TEST(PenumbraVisibility, MatchesRayCastingThroughTheScene)
{
    // 64 x 64 light samples on a grid: along each axis the hidden fraction is off by at
    // most one sample row, 1/64.
    constexpr int kSamples = 64;
    for (const float thickness : {0.0f, 0.01f}) {
        PenumbraParams p;
        p.occluderThickness = thickness;
        const test::RayCaster rays(generatePenumbra(p));
        RectAreaLight light;
        light.center = {0.1f, 3.0f, -0.05f};  // off-centre, so that x and z differ
        light.size = {0.6f, 0.4f};
        // The documented O(t) error of the thin-occluder assumption for t > 0.
        const double tolerance = 2.0 / kSamples + (thickness > 0.0f ? 0.01 : 0.0);
        for (const glm::dvec2 at : {glm::dvec2(0, 0), glm::dvec2(0.62, 0.1), glm::dvec2(0.7, -0.2), glm::dvec2(-0.75, 0.3),
                                    glm::dvec2(0.2, 0.68), glm::dvec2(0.66, 0.66), glm::dvec2(-0.6, -0.7), glm::dvec2(2, 0)}) {
            int visible = 0;
            for (int i = 0; i < kSamples; ++i) {
                for (int j = 0; j < kSamples; ++j) {
                    const glm::dvec3 l{light.center.x + ((i + 0.5) / kSamples - 0.5) * light.size.x, light.center.y,
                                       light.center.z + ((j + 0.5) / kSamples - 0.5) * light.size.y};
                    // A hair above the ground, so that the ground itself never blocks.
                    visible += !rays.segmentBlocked({at.x, 1e-6, at.y}, l);
                }
            }
            const double traced = double(visible) / (kSamples * kSamples);
            EXPECT_NEAR(visibility(p, light, at.x, at.y), traced, tolerance) << "thickness " << thickness << " at " << at.x << ", " << at.y;
        }
    }
}

TEST(PenumbraVisibility, RejectsALightBelowTheOccluder)
{
    const PenumbraParams p;
    RectAreaLight light;
    light.center.y = 1.0f;
    EXPECT_NE(errorOf([&] { visibility(p, light, 0, 0); }).find("must be finite and above the occluder's top"), std::string::npos);
    light.center.y = 4.0f;
    light.size.x = -1.0f;
    EXPECT_NE(errorOf([&] { visibility(p, light, 0, 0); }).find("sides must be finite and >= 0"), std::string::npos);
}
