#include "scene/gltf/Geometry.h"

#include "scene/gltf/Accessors.h"

#include <fmt/format.h>

#include <numeric>

namespace penumbra::scene::gltf {
namespace {

const char* modeName(int mode)
{
    switch (mode) {
    case TINYGLTF_MODE_POINTS: return "POINTS";
    case TINYGLTF_MODE_LINE: return "LINES";
    case TINYGLTF_MODE_LINE_LOOP: return "LINE_LOOP";
    case TINYGLTF_MODE_LINE_STRIP: return "LINE_STRIP";
    case TINYGLTF_MODE_TRIANGLES: return "TRIANGLES";
    case TINYGLTF_MODE_TRIANGLE_STRIP: return "TRIANGLE_STRIP";
    case TINYGLTF_MODE_TRIANGLE_FAN: return "TRIANGLE_FAN";
    default: return nullptr;
    }
}

// glTF 2.0 §3.7.2.1: strip triangle i = {v_i, v_{i+1+i%2}, v_{i+2-i%2}},
// fan triangle i = {v_{i+1}, v_{i+2}, v_0}.
std::vector<uint32_t> toTriangleList(const Document& doc, std::string_view element, int mode,
                                     const std::vector<uint32_t>& corners, bool indexed)
{
    const size_t n = corners.size();
    if (mode == TINYGLTF_MODE_TRIANGLES) {
        if (n % 3 != 0) {
            doc.warn(element, fmt::format("{} {} not a multiple of 3; the last {} are ignored", n,
                                          indexed ? "indices are" : "vertices (no indices) are", n % 3));
        }
        return {corners.begin(), corners.begin() + std::ptrdiff_t(n - n % 3)};
    }
    std::vector<uint32_t> list;
    if (n < 3) return list;
    list.reserve(3 * (n - 2));
    for (size_t i = 0; i + 2 < n; ++i) {
        if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
            list.insert(list.end(), {corners[i], corners[i + 1 + i % 2], corners[i + 2 - i % 2]});
        } else {
            list.insert(list.end(), {corners[i + 1], corners[i + 2], corners[0]});
        }
    }
    return list;
}

} // namespace

std::optional<Mesh> convertPrimitive(const Document& doc, int meshIndex, int primitiveIndex, GeometryBudget& budget)
{
    const tinygltf::Mesh& source = doc.model.meshes[size_t(meshIndex)];
    const tinygltf::Primitive& primitive = source.primitives[size_t(primitiveIndex)];
    const std::string element = fmt::format("/meshes/{}/primitives/{}", meshIndex, primitiveIndex);

    const char* mode = modeName(primitive.mode);
    if (!mode) doc.fail(element + "/mode", fmt::format("{} is not a glTF primitive mode (0 to 6)", primitive.mode));
    if (primitive.mode < TINYGLTF_MODE_TRIANGLES) {
        doc.warn(element, fmt::format("mode {} ({}) draws no triangles; primitive skipped", primitive.mode, mode));
        return std::nullopt;
    }
    auto attribute = [&](const char* name) {
        auto it = primitive.attributes.find(name);
        return it == primitive.attributes.end() ? -1 : it->second;
    };
    const std::string attributes = element + "/attributes/";
    const int positionAccessor = attribute("POSITION");
    if (positionAccessor < 0) {
        doc.warn(element, "no POSITION attribute; primitive skipped");
        return std::nullopt;
    }

    const CountLimit vertexLimit{budget.vertices, fmt::format("vertices left of the limit of {} per file",
                                                              doc.options.maxVertices)};
    const std::vector<float> positions =
        readAttribute(doc, positionAccessor, attributes + "POSITION", AttributeKind::Position, vertexLimit);
    const size_t vertexCount = positions.size() / 3;
    auto readMatching = [&](const char* name, AttributeKind kind) {
        const int accessor = attribute(name);
        if (accessor < 0) return std::vector<float>{};
        const size_t count = accessorCount(doc, accessor, attributes + name);
        if (count != vertexCount) {
            doc.fail(attributes + name, fmt::format("accessor {} has {} elements, POSITION has {}", accessor, count, vertexCount));
        }
        return readAttribute(doc, accessor, attributes + name, kind, {vertexCount, "POSITION's count"});
    };
    const std::vector<float> normals = readMatching("NORMAL", AttributeKind::Normal);
    const std::vector<float> uvs = readMatching("TEXCOORD_0", AttributeKind::TexCoord);
    size_t zeroNormals = 0;
    for (size_t i = 0; i + 2 < normals.size(); i += 3) {
        zeroNormals += normals[i] == 0.0f && normals[i + 1] == 0.0f && normals[i + 2] == 0.0f;
    }
    if (zeroNormals > 0) {
        doc.warn(attributes + "NORMAL", fmt::format("{} zero-length normal(s); they are generated", zeroNormals));
    }

    // A list of t triangles has 3t indices, a strip or fan t + 2.
    const CountLimit cornerLimit{3 * budget.triangles + 2,
                                 fmt::format("indices for the {} triangles left of the limit of {} per file", budget.triangles,
                                             doc.options.maxTriangles)};
    std::vector<uint32_t> corners;
    if (primitive.indices >= 0) {
        corners = readIndices(doc, primitive.indices, element + "/indices", cornerLimit);
        for (size_t i = 0; i < corners.size(); ++i) {
            if (corners[i] >= vertexCount) {
                doc.fail(element + "/indices", fmt::format("index {} at position {} (accessor {}) is out of range of {} vertices",
                                                           corners[i], i, primitive.indices, vertexCount));
            }
        }
    } else {
        corners.resize(vertexCount);
        std::iota(corners.begin(), corners.end(), 0u);
    }
    std::vector<uint32_t> triangles = toTriangleList(doc, element, primitive.mode, corners, primitive.indices >= 0);
    const uint64_t triangleCount = triangles.size() / 3;
    if (triangleCount > budget.triangles) {
        doc.fail(element, fmt::format("{} triangles exceed the {} left of the limit of {} triangles per file", triangleCount,
                                      budget.triangles, doc.options.maxTriangles));
    }
    budget.vertices -= vertexCount;
    budget.triangles -= triangleCount;
    if (!primitive.targets.empty()) doc.note(element, "morph targets ignored: the base geometry is loaded");

    Mesh mesh;
    mesh.name = source.name.empty() ? fmt::format("mesh{}", meshIndex) : source.name;
    if (source.primitives.size() > 1) mesh.name += fmt::format("#{}", primitiveIndex);
    mesh.vertices.resize(vertexCount);
    for (size_t i = 0; i < vertexCount; ++i) {
        Vertex& v = mesh.vertices[i];
        v.position = {positions[3 * i], positions[3 * i + 1], positions[3 * i + 2]};
        v.normal = normals.empty() ? glm::vec3(0.0f) : glm::vec3(normals[3 * i], normals[3 * i + 1], normals[3 * i + 2]);
        v.uv = uvs.empty() ? glm::vec2(0.0f) : glm::vec2(uvs[2 * i], uvs[2 * i + 1]);
    }
    mesh.indices = std::move(triangles);
    return mesh;
}

} // namespace penumbra::scene::gltf
