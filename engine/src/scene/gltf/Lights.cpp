#include "scene/gltf/Lights.h"

#include "penumbra/core/ShortText.h"

#include <fmt/format.h>
#include <glm/gtc/constants.hpp>

#include <algorithm>
#include <cmath>

namespace penumbra::scene::gltf {
namespace {

constexpr const char* kExtension = "KHR_lights_punctual";

// The index in the node's {"KHR_lights_punctual": {"light": i}}, or -1.
int lightIndexOf(const Document& doc, int node)
{
    const tinygltf::ExtensionMap& extensions = doc.model.nodes[size_t(node)].extensions;
    auto it = extensions.find(kExtension);
    if (it == extensions.end()) return -1;
    const std::string path = fmt::format("/nodes/{}/extensions/{}/light", node, kExtension);
    const tinygltf::Value& value = it->second;
    if (!value.IsObject() || !value.Has("light") || !value.Get("light").IsNumber()) {
        doc.fail(path, "is missing or not a number");
    }
    const double index = value.Get("light").GetNumberAsDouble();
    if (!(index >= 0.0 && index < double(doc.model.lights.size())) || index != std::floor(index)) {
        doc.fail(path, fmt::format("light {} does not exist ({} lights)", index, doc.model.lights.size()));
    }
    return int(index);
}

Light convertLight(const Document& doc, int index)
{
    const tinygltf::Light& source = doc.model.lights[size_t(index)];
    const std::string path = fmt::format("/extensions/{}/lights/{}", kExtension, index);
    Light light;
    if (source.type == "directional") {
        light.type = LightType::Directional;
    } else if (source.type == "point") {
        light.type = LightType::Point;
    } else if (source.type == "spot") {
        light.type = LightType::Spot;
    } else {
        doc.fail(path + "/type", fmt::format("'{}' is not directional, point or spot", core::shortText(source.type)));
    }
    const std::vector<double>& color = source.color;
    if (!color.empty()) {
        if (color.size() != 3 || !std::all_of(color.begin(), color.end(), [](double c) { return std::isfinite(c) && c >= 0.0; })) {
            doc.fail(path + "/color", "must be 3 finite numbers >= 0");
        }
        light.color = glm::vec3(color[0], color[1], color[2]);
    }
    if (!std::isfinite(source.intensity) || source.intensity < 0.0) {
        doc.fail(path + "/intensity", fmt::format("must be a finite number >= 0, got {}", source.intensity));
    }
    light.intensity = float(source.intensity);
    if (light.type == LightType::Spot) {
        const double inner = source.spot.innerConeAngle, outer = source.spot.outerConeAngle;
        if (!(inner >= 0.0 && inner < outer && outer <= glm::half_pi<double>())) {
            doc.fail(path + "/spot", fmt::format("innerConeAngle {} and outerConeAngle {} must satisfy "
                                                 "0 <= inner < outer <= pi/2",
                                                 inner, outer));
        }
        light.innerConeDeg = float(glm::degrees(inner));
        light.outerConeDeg = float(glm::degrees(outer));
    }
    return light;
}

} // namespace

std::optional<GltfLight> lightOfNode(const Document& doc, int node, uint32_t graphNode, const glm::mat4& world)
{
    const int index = lightIndexOf(doc, node);
    if (index < 0) return std::nullopt;
    GltfLight out;
    out.light = convertLight(doc, index);
    const std::string& name = doc.model.lights[size_t(index)].name;
    out.name = name.empty() ? fmt::format("light{}", index) : name;
    out.node = graphNode;
    out.light.position = glm::vec3(world[3]);
    if (out.light.type != LightType::Point) {
        const glm::vec3 direction = glm::mat3(world) * glm::vec3(0.0f, 0.0f, -1.0f);
        const float length = glm::length(direction);
        if (!(length > 1e-12f && std::isfinite(length))) {
            doc.warn(fmt::format("/nodes/{}", node), fmt::format("the node's transform leaves light '{}' no direction "
                                                                 "(zero scale); light skipped",
                                                                 core::shortText(out.name)));
            return std::nullopt;
        }
        out.light.direction = direction / length;
    }
    return out;
}

} // namespace penumbra::scene::gltf
