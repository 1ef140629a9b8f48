// A config's scene made of its parts (RenderConfig.h: SceneSource): each glTF file or
// generator built on its own, then moved under a root node of its own that carries the
// part's transform (scene::appendUnderRoot), so that node animations, instancing and the
// BVH see one ordinary scene graph.
#include "penumbra/config/Run.h"
#include "penumbra/core/Error.h"
#include "penumbra/core/ShortText.h"
#include "penumbra/scene/Generators.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>

namespace penumbra::config {
namespace {

// What one scene may hold, all its parts together: as much as one generated scene may
// (a single part keeps every limit it had). Each part is also bounded on its own, by
// the generator's or the glTF loader's limits, before it is built.
constexpr uint64_t kMaxSceneTriangles = scene::kMaxGeneratedTriangles;
constexpr uint64_t kMaxSceneInstances = scene::kMaxGeneratedInstances;

scene::Scene buildPart(const ScenePart& part, std::vector<scene::GltfLight>* fileLights)
{
    if (part.kind == ScenePart::Kind::Generator) return scene::generateScene(part.generator, part.params);
    scene::GltfLoadReport report;
    scene::GltfLoadOptions options;
    options.allowedRoots = part.allowedRoots;
    scene::Scene scene = scene::loadGltf(part.gltf, report, options);
    if (scene.instances.empty()) throw Error(fmt::format("{}: the glTF file has no triangles to render", displayPath(part.gltf)));
    if (fileLights) fileLights->insert(fileLights->end(), report.lights.begin(), report.lights.end());
    return scene;
}

// A light of a part's file, placed by the part's transform `m` (as the loader places it
// by its node's: the position transformed, the direction by m's linear part). Scaling a
// part by s moves its lights with it; radiant intensity times s² keeps the irradiance it
// gives the scaled geometry (for an uneven scale, s is the geometric mean of the three).
scene::GltfLight placeLight(scene::GltfLight light, const glm::dmat4& m, const glm::dvec3& scale, uint32_t nodeBase)
{
    light.node += nodeBase;
    scene::Light& l = light.light;
    l.position = glm::vec3(m * glm::dvec4(glm::dvec3(l.position), 1.0));
    const glm::dvec3 direction = glm::dmat3(m) * glm::dvec3(l.direction);
    l.direction = glm::vec3(glm::normalize(direction));
    if (l.type != scene::LightType::Directional) l.intensity = float(l.intensity * std::pow(scale.x * scale.y * scale.z, 2.0 / 3.0));
    return light;
}

// Where part `part`'s nodes are in a scene that buildScene made: from its root node (the
// part-th node without a parent; parts are appended in order) to the next part's root.
std::pair<uint32_t, uint32_t> partNodes(const scene::SceneGraph& graph, size_t part)
{
    uint32_t begin = uint32_t(graph.size()), end = uint32_t(graph.size());
    size_t roots = 0;
    for (uint32_t n = 0; n < graph.size(); ++n) {
        if (graph.node(n).parent != scene::kNoParent) continue;
        if (roots == part) begin = n;
        if (roots == part + 1) {
            end = n;
            break;
        }
        ++roots;
    }
    return {begin, end};
}

// The clip part `index` plays, as an index into scene.animations. Its "animation" is the
// name of one of its file's clips, or an index among them.
size_t partClip(const RenderConfig& config, const scene::Scene& scene, size_t index)
{
    const ScenePart& part = config.scene.parts[index];
    const auto [begin, end] = partNodes(scene.graph, index);
    // A clip belongs to the part whose nodes it moves (the loader keeps only clips with
    // a channel).
    std::vector<size_t> clips;
    for (size_t i = 0; i < scene.animations.size(); ++i) {
        const uint32_t node = scene.animations[i].channels.empty() ? end : scene.animations[i].channels.front().node;
        if (node >= begin && node < end) clips.push_back(i);
    }
    for (size_t clip : clips) {
        if (scene.animations[clip].name == part.animation) return clip;
    }
    const std::string& wanted = part.animation;
    if (std::all_of(wanted.begin(), wanted.end(), [](char c) { return c >= '0' && c <= '9'; }) && wanted.size() < 9) {
        const size_t i = std::stoul(wanted);
        if (i < clips.size()) return clips[i];
    }
    std::vector<std::string> names;
    for (size_t clip : clips) names.push_back(fmt::format("\"{}\"", core::shortText(scene.animations[clip].name)));
    throw ConfigError(fmt::format("{}: {}/animation: {} has no animation \"{}\"; {}", displayPath(config.file), part.pointer,
                                  displayPath(part.gltf), core::shortText(wanted),
                                  names.empty() ? std::string("it has none that can play")
                                                : fmt::format("its animations: {} (or their index)", fmt::join(names, ", "))));
}

} // namespace

glm::dmat4 PartTransform::matrix() const
{
    return glm::translate(glm::dmat4(1.0), translation) * glm::mat4_cast(rotation) * glm::scale(glm::dmat4(1.0), scale);
}

std::string ScenePart::sourceName() const { return kind == Kind::Gltf ? gltf.filename().string() : generator; }

bool SceneSource::hasGltf() const
{
    return std::any_of(parts.begin(), parts.end(), [](const ScenePart& p) { return p.kind == ScenePart::Kind::Gltf; });
}

bool SceneSource::playsClip() const
{
    return std::any_of(parts.begin(), parts.end(), [](const ScenePart& p) { return !p.animation.empty(); });
}

std::string SceneSource::describe() const
{
    std::vector<std::string> names;
    for (const ScenePart& part : parts) names.push_back(part.sourceName());
    return fmt::format("{}", fmt::join(names, " + "));
}

scene::Scene buildScene(const SceneSource& source, std::vector<scene::GltfLight>* fileLights)
{
    scene::Scene scene;
    for (const ScenePart& part : source.parts) {
        std::vector<scene::GltfLight> partLights;
        scene::Scene built;
        try {
            built = buildPart(part, fileLights ? &partLights : nullptr);
        } catch (const ConfigError&) {
            throw;
        } catch (const Error& e) {
            // A generator's parameter error names the parameter, a file's the element; add
            // which part.
            throw Error(fmt::format("{}: {}", part.pointer, e.what()));
        }
        const glm::dmat4 m = part.transform.matrix();
        const uint32_t root = scene::appendUnderRoot(scene, std::move(built), part.name, glm::mat4(m));
        for (const scene::GltfLight& light : partLights) fileLights->push_back(placeLight(light, m, part.transform.scale, root + 1));
        if (scene.triangleCount() > kMaxSceneTriangles || scene.instances.size() > kMaxSceneInstances) {
            throw Error(fmt::format("{}: the scene's parts up to this one draw {} triangles with {} instances; a scene may "
                                    "draw at most {} triangles with {} instances",
                                    part.pointer, scene.triangleCount(), scene.instances.size(), kMaxSceneTriangles,
                                    kMaxSceneInstances));
        }
    }
    return scene;
}

std::vector<size_t> playedClips(const RenderConfig& config, const scene::Scene& scene)
{
    std::vector<size_t> clips;
    for (size_t i = 0; i < config.scene.parts.size(); ++i) {
        if (!config.scene.parts[i].animation.empty()) clips.push_back(partClip(config, scene, i));
    }
    return clips;
}

std::vector<PartSummary> summarizeParts(const SceneSource& source, const scene::Scene& scene)
{
    std::vector<PartSummary> summaries;
    for (size_t i = 0; i < source.parts.size(); ++i) {
        const auto [begin, end] = partNodes(scene.graph, i);
        PartSummary s;
        for (const scene::Instance& instance : scene.instances) {
            if (instance.node < begin || instance.node >= end) continue;
            ++s.instances;
            s.triangles += scene.meshes[instance.mesh].indices.size() / 3;
            s.bounds.extend(instance.worldBounds);
        }
        summaries.push_back(s);
    }
    return summaries;
}

} // namespace penumbra::config
