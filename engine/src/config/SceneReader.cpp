#include "config/SceneReader.h"

#include "penumbra/core/Error.h"
#include "penumbra/core/ShortText.h"

#include <fmt/format.h>

#include <cmath>
#include <set>

using nlohmann::json;
namespace fs = std::filesystem;

namespace penumbra::config {
namespace {

// A translation further out than this leaves float world positions no finer than
// ~60 units: the limit is about what can be drawn, not what can be read.
constexpr double kMaxTranslation = 1e9;
// Euler angles beyond a turn either way are a typo more likely than an intent.
constexpr double kMaxRotationDeg = 360.0;
// How far a quaternion's length may be from 1: four hand-typed decimals (0.7071) are
// within it, a vector that is not a rotation ([0, 1, 0, 1]) is not.
constexpr double kUnitQuaternionTolerance = 1e-2;

// "allowed_roots": folders besides a glTF model's own whose files its URIs may name
// (GltfLoadOptions::allowedRoots), relative to the config's folder.
std::vector<fs::path> readAllowedRoots(ObjectReader& r, const fs::path& configFile)
{
    std::vector<fs::path> roots;
    const json* v = r.find("allowed_roots");
    if (!v) return roots;
    const std::string at = r.path("allowed_roots");
    if (!v->is_array()) r.fail(at, fmt::format("must be an array of folder names, got {}", core::shortJson(*v)));
    for (size_t i = 0; i < v->size(); ++i) {
        const json& root = (*v)[i];
        const std::string element = fmt::format("{}/{}", at, i);
        if (!root.is_string() || root.get_ref<const std::string&>().empty()) {
            r.fail(element, fmt::format("must be a folder name, got {}", core::shortJson(root)));
        }
        fs::path folder = root.get<std::string>();
        if (folder.is_relative()) folder = configFile.parent_path() / folder;
        std::error_code ec;
        if (!fs::is_directory(folder, ec)) r.fail(element, fmt::format("folder not found: {}", displayPath(folder)));
        roots.push_back(std::move(folder));
    }
    return roots;
}

// An array of `n` numbers, each in [lo, hi] (or (lo, hi] with loOpen).
std::vector<double> readNumbers(const ObjectReader& r, const json& v, const std::string& at, size_t n, const char* what,
                                double lo, double hi, bool loOpen)
{
    if (!v.is_array() || v.size() != n) r.fail(at, fmt::format("must be {}, got {}", what, core::shortJson(v)));
    std::vector<double> out;
    for (size_t i = 0; i < n; ++i) out.push_back(r.checkNumber(v[i], fmt::format("{}/{}", at, i), lo, hi, loOpen));
    return out;
}

PartTransform readTransform(ObjectReader& r)
{
    PartTransform t;
    if (const json* v = r.find("translation")) {
        const std::vector<double> x = readNumbers(r, *v, r.path("translation"), 3, "[x, y, z]", -kMaxTranslation,
                                                  kMaxTranslation, false);
        t.translation = {x[0], x[1], x[2]};
    }
    const json* euler = r.find("rotation_deg");
    const json* quaternion = r.find("rotation");
    if (euler && quaternion) {
        r.fail(r.path("rotation"), "give either \"rotation_deg\" (Euler angles) or \"rotation\" (a quaternion), not both");
    }
    if (euler) {
        const std::vector<double> a = readNumbers(r, *euler, r.path("rotation_deg"), 3,
                                                  "[x, y, z] in degrees (R = Rx · Ry · Rz)", -kMaxRotationDeg,
                                                  kMaxRotationDeg, false);
        t.rotationDeg = glm::dvec3(a[0], a[1], a[2]);
        // As a node track's rotation_deg (glm::eulerAngleXYZ): about x, then y, then z of
        // the rotated frame, i.e. Rx · Ry · Rz applied to column vectors.
        t.rotation = glm::angleAxis(glm::radians(a[0]), glm::dvec3(1, 0, 0)) *
                     glm::angleAxis(glm::radians(a[1]), glm::dvec3(0, 1, 0)) *
                     glm::angleAxis(glm::radians(a[2]), glm::dvec3(0, 0, 1));
    }
    if (quaternion) {
        const std::string at = r.path("rotation");
        const std::vector<double> q = readNumbers(r, *quaternion, at, 4, "a unit quaternion [x, y, z, w] (glTF's order)",
                                                  -1.0 - kUnitQuaternionTolerance, 1.0 + kUnitQuaternionTolerance, false);
        const glm::dquat rotation(q[3], q[0], q[1], q[2]);
        const double length = glm::length(rotation);
        if (!(std::abs(length - 1.0) <= kUnitQuaternionTolerance)) {
            r.fail(at, fmt::format("must be a unit quaternion [x, y, z, w] (length 1 ± {}), got {} of length {:.6g}",
                                   kUnitQuaternionTolerance, core::shortJson(*quaternion), length));
        }
        t.rotation = rotation / length;
    }
    if (const json* v = r.find("scale")) {
        const std::string at = r.path("scale");
        if (v->is_number()) {
            t.scale = glm::dvec3(r.checkNumber(*v, at, 0.0, kMaxPartScale, true));
        } else if (v->is_array()) {
            const std::vector<double> s = readNumbers(r, *v, at, 3, "a number or [sx, sy, sz]", 0.0, kMaxPartScale, true);
            t.scale = {s[0], s[1], s[2]};
        } else {
            r.fail(at, fmt::format("must be a number in (0, {}] or [sx, sy, sz] of such, got {}", kMaxPartScale,
                                   core::shortJson(*v)));
        }
    }
    return t;
}

// The glTF file's animation that plays: a name, or an index into the file's animations;
// buildScene checks it exists.
std::string readClip(ObjectReader& r)
{
    const json* animation = r.find("animation");
    if (!animation) return {};
    if (animation->is_string() && !animation->get<std::string>().empty()) return animation->get<std::string>();
    if (animation->is_number_integer() && animation->get<int64_t>() >= 0) return std::to_string(animation->get<int64_t>());
    r.fail(r.path("animation"), fmt::format("must be the name or index of an animation of the glTF file, got {}",
                                            core::shortJson(*animation)));
}

// One part: the scene object itself in the single-part form, an element of "parts"
// otherwise. Leaves unknown keys to the caller's finish().
ScenePart readPart(ObjectReader& r, const Locator& locator, const fs::path& configFile, size_t index)
{
    ScenePart part;
    part.pointer = r.pointer();
    part.name = r.string("name", fmt::format("part{}", index));
    const json* gltf = r.find("gltf");
    const json* generator = r.find("generator");
    if (gltf && generator) r.fail(r.pointer(), "give either \"gltf\" or \"generator\", not both");
    part.transform = readTransform(r);
    if (gltf) {
        part.kind = ScenePart::Kind::Gltf;
        if (!gltf->is_string() || gltf->get<std::string>().empty()) {
            r.fail(r.path("gltf"), fmt::format("must be a file path, got {}", core::shortJson(*gltf)));
        }
        part.gltf = gltf->get<std::string>();
        if (part.gltf.is_relative()) part.gltf = configFile.parent_path() / part.gltf;
        std::error_code ec;
        if (!fs::is_regular_file(part.gltf, ec)) r.fail(r.path("gltf"), fmt::format("file not found: {}", displayPath(part.gltf)));
        part.allowedRoots = readAllowedRoots(r, configFile);
        part.animation = readClip(r);
        return part;
    }
    part.generator = r.choice("generator", part.generator, scene::generatorNames());
    if (const json* params = r.find("params")) {
        ObjectReader p(*params, locator, r.path("params"));
        // Each value checked against the generator's table where the file gives it; the
        // bounds between parameters are the generator's, when the scene is built.
        for (const scene::GeneratorParam& parameter : scene::generatorParameters(part.generator)) {
            const json* v = p.find(parameter.name);
            if (!v) continue;
            const std::string text = v->is_string() ? v->get<std::string>() : v->dump();
            if (!(v->is_number() || v->is_string()) || !scene::parseGeneratorValue(parameter, text)) {
                p.fail(p.path(parameter.name), fmt::format("must be {} (generator {}, parameter {}: {}), got {}",
                                                           scene::describeRange(parameter), part.generator, parameter.name,
                                                           parameter.doc, core::shortJson(*v)));
            }
            part.params.emplace_back(parameter.name, text);
        }
        p.finish(fmt::format("for the {} generator", part.generator));
    }
    return part;
}

const char* partContext(const ScenePart& part)
{
    return part.kind == ScenePart::Kind::Gltf ? "for a glTF part" : "for a generator part";
}

} // namespace

SceneSource readScene(ObjectReader& parent, const fs::path& configFile)
{
    SceneSource source;
    const json* v = parent.find("scene");
    if (!v) return source;
    ObjectReader r(*v, parent.locator(), "/scene");
    const json* parts = r.find("parts");
    if (!parts) {
        source.parts = {readPart(r, parent.locator(), configFile, 0)};
        r.finish(partContext(source.parts[0]));
        return source;
    }
    // Over an included scene, its keys are removed with null (a merge patch): what is
    // left beside "parts" is a second description of the scene.
    for (auto it = v->begin(); it != v->end(); ++it) {
        if (it.key() != "parts") {
            r.fail(r.path(it.key()), "give either \"parts\" or one part's keys, not both (each part has its own; over "
                                     "an included scene, set its keys to null)");
        }
    }
    const std::string at = r.path("parts");
    if (!parts->is_array() || parts->empty() || parts->size() > kMaxSceneParts) {
        r.fail(at, fmt::format("must be an array of 1 to {} parts (objects with \"gltf\" or \"generator\"), got {}",
                               kMaxSceneParts, parts->is_array() ? fmt::format("{} parts", parts->size())
                                                                 : core::shortJson(*parts)));
    }
    source.listed = true;
    source.parts.clear();
    std::set<std::string> names;
    for (size_t i = 0; i < parts->size(); ++i) {
        ObjectReader p((*parts)[i], parent.locator(), fmt::format("{}/{}", at, i));
        source.parts.push_back(readPart(p, parent.locator(), configFile, i));
        p.finish(partContext(source.parts.back()));
        if (!names.insert(source.parts.back().name).second) {
            p.fail(p.path("name"), fmt::format("duplicate part name {} (each part's root node needs its own name)",
                                               core::shortJson(source.parts.back().name)));
        }
    }
    return source;
}

} // namespace penumbra::config
