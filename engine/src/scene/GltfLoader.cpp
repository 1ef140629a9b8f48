#include "penumbra/scene/GltfLoader.h"

#include "penumbra/core/Error.h"
#include "penumbra/core/ShortText.h"
#include "penumbra/io/ReadFile.h"
#include "scene/gltf/Animations.h"
#include "scene/gltf/Document.h"
#include "scene/gltf/Geometry.h"
#include "scene/gltf/Images.h"
#include "scene/gltf/Lights.h"
#include "scene/gltf/Materials.h"
#include "scene/gltf/Nodes.h"
#include "scene/gltf/Preflight.h"
#include "scene/gltf/Uri.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cstring>
#include <optional>
#include <sstream>

namespace fs = std::filesystem;

namespace penumbra::scene {
namespace {

using gltf::Document;

// Extensions whose data the loader reads. Any other in extensionsRequired refuses
// the file; any other in extensionsUsed is a warning (glTF lets a reader ignore those).
constexpr std::array<std::string_view, 1> kSupportedExtensions{"KHR_lights_punctual"};

bool supported(const std::string& extension)
{
    return std::find(kSupportedExtensions.begin(), kSupportedExtensions.end(), extension) != kSupportedExtensions.end();
}

bool isGlb(const std::vector<unsigned char>& bytes) { return bytes.size() >= 4 && std::memcmp(bytes.data(), "glTF", 4) == 0; }

[[noreturn]] void failVersion1(const std::string& file, std::string_view evidence)
{
    throw AssetError(fmt::format("{}: glTF 1.0 is not supported ({}); convert the file to glTF 2.0", file, evidence));
}

void checkGlbHeader(const std::string& file, const std::vector<unsigned char>& bytes)
{
    if (bytes.size() < 12) throw AssetError(fmt::format("{}: GLB header truncated ({} bytes)", file, bytes.size()));
    uint32_t version;
    std::memcpy(&version, bytes.data() + 4, sizeof version);
    if (version == 1) failVersion1(file, "binary glTF version 1");
    if (version != 2) throw AssetError(fmt::format("{}: binary glTF version {} is not supported (expected 2)", file, version));
}

// A .gltf tinygltf could not parse may be glTF 1.0, whose top-level collections are
// objects keyed by id where glTF 2.0 has arrays.
void refuseGltf1Layout(const std::string& file, const nlohmann::json& doc)
{
    if (!doc.is_object()) return;
    for (const char* key : {"accessors", "bufferViews", "buffers", "meshes", "nodes", "materials"}) {
        auto it = doc.find(key);
        if (it != doc.end() && it->is_object()) failVersion1(file, fmt::format("its top-level '{}' is an object", key));
    }
}

void checkRequiredExtensions(const std::string& file, const tinygltf::Model& model)
{
    std::vector<std::string> unsupported;
    for (const std::string& extension : model.extensionsRequired) {
        if (!supported(extension)) unsupported.push_back(extension);
    }
    if (unsupported.size() == 1) {
        throw AssetError(
            fmt::format("{}: required extension {} is not supported", file, core::shortText(unsupported[0])));
    }
    if (!unsupported.empty()) {
        throw AssetError(fmt::format("{}: required extensions {} are not supported", file,
                                     core::shortText(fmt::format("{}", fmt::join(unsupported, ", ")))));
    }
}

void checkVersion(const Document& doc)
{
    const tinygltf::Asset& asset = doc.model.asset;
    auto major = [](const std::string& version) { return std::atoi(version.c_str()); };
    if (major(asset.version) == 1) failVersion1(doc.file, fmt::format("asset.version {}", core::shortJson(asset.version)));
    if (major(asset.version) != 2) {
        doc.fail("/asset/version",
                 fmt::format("glTF {} is not supported; penumbra reads glTF 2.0", core::shortJson(asset.version)));
    }
    if (!asset.minVersion.empty() && asset.minVersion != "2.0") {
        doc.fail("/asset/minVersion",
                 fmt::format("the file needs glTF {}; penumbra reads glTF 2.0", core::shortText(asset.minVersion)));
    }
}

// tinygltf's error text, one line, shortened: it quotes values whole (a data: URI it
// cannot decode).
std::string describeParseError(const std::string& err)
{
    const std::string text = gltf::oneLine(err);
    constexpr std::string_view kJson = "[json.exception.";
    if (text.rfind(kJson, 0) == 0) {
        const size_t end = text.find("] ");
        return "malformed JSON: " + core::shortText(end == std::string::npos ? text : text.substr(end + 2));
    }
    return "cannot parse: " + core::shortText(text);
}

// The deepest nesting of objects and arrays in JSON text, by one pass over it (strings and
// their escapes skipped): no recursion, whatever the depth. Stops counting at `most` + 1.
int jsonNestingDepth(std::string_view text, int most)
{
    int depth = 0, deepest = 0;
    bool inString = false;
    for (size_t i = 0; i < text.size() && deepest <= most; ++i) {
        const char c = text[i];
        if (inString) {
            if (c == '\\') ++i;
            else if (c == '"') inString = false;
        } else if (c == '"') {
            inString = true;
        } else if (c == '{' || c == '[') {
            deepest = std::max(deepest, ++depth);
        } else if (c == '}' || c == ']') {
            depth = std::max(depth - 1, 0);
        }
    }
    return deepest;
}

// The file's JSON: the whole of a .gltf, a .glb's first chunk (as far as the file holds
// it; tinygltf reports a malformed one).
std::string_view jsonText(const std::vector<unsigned char>& bytes)
{
    const char* data = reinterpret_cast<const char*>(bytes.data());
    if (!isGlb(bytes)) return {data, bytes.size()};
    if (bytes.size() < 20) return {};
    uint32_t length;
    std::memcpy(&length, bytes.data() + 12, sizeof length);
    return {data + 20, std::min<size_t>(length, bytes.size() - 20)};
}

// Parses the file with tinygltf into `model`, its external files read through `files`.
// Required extensions are checked even when tinygltf fails: a Draco-compressed file fails
// there for want of the extension.
void parseModel(const fs::path& file, const GltfLoadOptions& options, gltf::ExternalFiles& files,
                gltf::ImageDecoder& images, uint64_t& bytesLeft, tinygltf::Model& model,
                std::vector<std::string>& tinygltfWarnings)
{
    const std::string name = core::shortText(file.string());
    std::vector<unsigned char> bytes;
    try {
        bytes = io::readRegularFile(file, bytesLeft, "a glTF file");
    } catch (const io::FileReadError& e) {
        throw AssetError(
            fmt::format("{}: {}", name, e.problem() == io::FileReadProblem::NotFound ? "glTF file not found" : e.reason()));
    }
    bytesLeft -= bytes.size();
    // tinygltf takes the length as unsigned int.
    if (bytes.size() > std::numeric_limits<unsigned int>::max()) {
        throw AssetError(fmt::format("{}: glTF file of {} bytes; 4 GiB is the most glTF allows", name, bytes.size()));
    }
    if (isGlb(bytes)) checkGlbHeader(name, bytes);
    if (jsonNestingDepth(jsonText(bytes), kMaxGltfNesting) > kMaxGltfNesting) {
        throw AssetError(fmt::format("{}: its JSON nests objects and arrays deeper than {} levels (glTF needs 6; "
                                     "look in extras and extensions)",
                                     name, kMaxGltfNesting));
    }
    // Within the nesting limit nlohmann's parse and the checks on it cannot recurse deep.
    // Parsed once for the preflight and, should tinygltf fail, the glTF 1.0 check.
    const nlohmann::json json = nlohmann::json::parse(jsonText(bytes), nullptr, false);
    gltf::preflight(name, json, files, options);

    tinygltf::TinyGLTF loader;
    files.install(loader);
    images.model = &model;
    images.maxImageTexels = options.maxImageTexels;
    images.texelsLeft = options.maxTotalTexels;
    images.install(loader);

    std::string err, warn;
    const auto size = static_cast<unsigned int>(bytes.size());
    const bool ok = isGlb(bytes)
                        ? loader.LoadBinaryFromMemory(&model, &err, &warn, bytes.data(), size, files.baseDir())
                        : loader.LoadASCIIFromString(&model, &err, &warn, reinterpret_cast<const char*>(bytes.data()), size,
                                                     files.baseDir());
    checkRequiredExtensions(name, model);
    if (!ok) {
        if (!isGlb(bytes)) refuseGltf1Layout(name, json);
        if (const std::string failure = files.firstBufferFailure(); !failure.empty()) {
            throw AssetError(fmt::format("{}: {}", name, failure));
        }
        throw AssetError(fmt::format("{}: {}", name, describeParseError(err)));
    }
    // tinygltf reports some schema violations (a missing required property) in `err`
    // and still succeeds; they are warnings here, like its own.
    for (const std::string* text : {&err, &warn}) {
        std::string line;
        for (std::istringstream lines(*text); std::getline(lines, line);) {
            if (!line.empty()) tinygltfWarnings.push_back("tinygltf: " + core::shortText(line));
        }
    }
}

void noteIgnoredFeatures(const Document& doc)
{
    const tinygltf::Model& model = doc.model;
    for (const std::string& extension : model.extensionsUsed) {
        if (!supported(extension)) {
            doc.warn("/extensionsUsed", fmt::format("extension {} is not supported; ignored", core::shortText(extension)));
        }
    }
    if (!model.cameras.empty()) {
        doc.note("/cameras", fmt::format("{} camera(s) ignored: the camera comes from the render config", model.cameras.size()));
    }
    if (!model.skins.empty()) {
        doc.note("/skins", fmt::format("{} skin(s) ignored: skinned meshes stay unposed under their node", model.skins.size()));
    }
}

// The scene meshes of glTF mesh `index`: its triangle primitives, repaired; a
// primitive with no triangle left is skipped with a warning.
std::vector<uint32_t> loadMesh(const Document& doc, int index, gltf::MaterialTable& materials, gltf::GeometryBudget& budget,
                               Scene& scene)
{
    std::vector<uint32_t> meshes;
    const tinygltf::Mesh& source = doc.model.meshes[size_t(index)];
    if (source.primitives.empty()) doc.warn(fmt::format("/meshes/{}", index), "has no primitives");
    for (size_t p = 0; p < source.primitives.size(); ++p) {
        std::optional<Mesh> mesh = gltf::convertPrimitive(doc, index, int(p), budget);
        if (!mesh) continue;
        const std::string element = fmt::format("/meshes/{}/primitives/{}", index, p);
        mesh->material = materials.sceneMaterial(source.primitives[p].material, element + "/material");
        const RepairReport repair = repairMesh(*mesh, doc.options.repair);
        if (repair.nonFiniteTriangles > 0) {
            doc.warn(element, fmt::format("{} triangle(s) with NaN or infinite corners dropped", repair.nonFiniteTriangles));
        }
        if (repair.replacedNormals > 0) {
            doc.warn(element, fmt::format("{} NaN or infinite normal(s) replaced", repair.replacedNormals));
        }
        if (mesh->indices.empty()) {
            doc.warn(element, "no triangle left after repair; primitive skipped");
            continue;
        }
        scene.meshes.push_back(std::move(*mesh));
        doc.report.meshes.push_back({element, repair});
        meshes.push_back(uint32_t(scene.meshes.size() - 1));
    }
    return meshes;
}

} // namespace

Scene loadGltf(const fs::path& file, GltfLoadReport& report, const GltfLoadOptions& options)
{
    report = {};
    uint64_t bytesLeft = options.maxBytesRead;
    gltf::ExternalFiles files(file, options.allowedRoots, bytesLeft, options.maxBytesRead);
    gltf::ImageDecoder images;
    tinygltf::Model model;
    std::vector<std::string> tinygltfWarnings;
    parseModel(file, options, files, images, bytesLeft, model, tinygltfWarnings);
    const Document doc{model, core::shortText(file.string()), options, report};
    checkVersion(doc);
    for (const std::string& warning : tinygltfWarnings) doc.warn("", warning);
    noteIgnoredFeatures(doc);

    Scene scene;
    const gltf::NodeMap nodes = gltf::buildSceneGraph(doc, scene.graph);
    scene.animations = gltf::loadAnimations(doc, nodes);
    gltf::MaterialTable materials(doc, images, files, scene);
    gltf::GeometryBudget budget{options.maxVertices, options.maxTriangles};
    std::vector<std::optional<std::vector<uint32_t>>> meshesOf(model.meshes.size());
    bool anyMesh = false;
    for (int index : nodes.loaded) {
        const tinygltf::Node& node = model.nodes[size_t(index)];
        const auto graphNode = uint32_t(nodes.graphNode[size_t(index)]);
        if (node.mesh != -1) {
            if (node.mesh < 0 || size_t(node.mesh) >= model.meshes.size()) {
                doc.fail(fmt::format("/nodes/{}/mesh", index),
                         fmt::format("mesh {} does not exist ({} meshes)", node.mesh, model.meshes.size()));
            }
            std::optional<std::vector<uint32_t>>& meshes = meshesOf[size_t(node.mesh)];
            if (!meshes) meshes = loadMesh(doc, node.mesh, materials, budget, scene);
            if (scene.instances.size() + meshes->size() > options.maxInstances) {
                doc.fail(fmt::format("/nodes/{}/mesh", index),
                         fmt::format("instances exceed the limit of {} per file", options.maxInstances));
            }
            for (uint32_t mesh : *meshes) scene.addInstance(mesh, graphNode);
            anyMesh = true;
        }
        if (auto light = gltf::lightOfNode(doc, index, graphNode, scene.graph.world(graphNode))) {
            report.lights.push_back(std::move(*light));
        }
    }
    if (scene.triangleCount() == 0) {
        doc.warn("", model.nodes.empty() ? "no triangles: the file has no nodes"
                     : !anyMesh          ? "no triangles: no node of the loaded scene has a mesh"
                                         : "no triangles: every primitive was skipped (see the warnings above)");
    }
    return scene;
}

} // namespace penumbra::scene
