#include "scene/gltf/Preflight.h"

#include "penumbra/core/Error.h"
#include "penumbra/core/ShortText.h"
#include "scene/gltf/Accessors.h"

#include <fmt/format.h>

#include <cstdint>
#include <map>
#include <string_view>

namespace penumbra::scene::gltf {
namespace {

using nlohmann::json;

[[noreturn]] void fail(const std::string& file, const std::string& element, const std::string& what)
{
    throw AssetError(fmt::format("{}: {}: {}", file, element, what));
}

// The bytes a base64 data URI decodes to (its payload's length without padding and
// whitespace, times 3/4); -1 when `uri` is not a base64 data URI.
int64_t dataUriBytes(std::string_view uri)
{
    if (uri.rfind("data:", 0) != 0) return -1;
    const size_t comma = uri.find(',');
    if (comma == std::string_view::npos || uri.substr(0, comma).find(";base64") == std::string_view::npos) return -1;
    int64_t symbols = 0;
    for (char c : uri.substr(comma + 1)) {
        if (c == '=' || c == ' ' || c == '\n' || c == '\r' || c == '\t') continue;
        ++symbols;
    }
    return symbols * 3 / 4;
}

// An index into a top-level array of `count` entries; false for anything else.
bool validIndex(const json& v, size_t count)
{
    return v.is_number_integer() && v.get<int64_t>() >= 0 && uint64_t(v.get<int64_t>()) < count;
}

uint64_t accessorCount(const json& accessors, const json& index)
{
    const json& a = accessors[index.get<size_t>()];
    const auto it = a.is_object() ? a.find("count") : a.end();
    return a.is_object() && it != a.end() && it->is_number_unsigned() ? it->get<uint64_t>() : 0;
}

// Whether accessor `index`'s elements fit in its buffer view as declared (no view: a
// sparse or zero accessor reads no buffer). One that does not is left to the loader,
// which names the view it overflows; the limit checks here take only consistent ones.
bool fitsItsView(const json& doc, const json& accessors, const json& index)
{
    const json& a = accessors[index.get<size_t>()];
    if (!a.is_object()) return false;
    const auto view = a.find("bufferView");
    if (view == a.end()) return true;
    const auto views = doc.find("bufferViews");
    if (views == doc.end() || !views->is_array() || !validIndex(*view, views->size())) return false;
    const json& v = (*views)[view->get<size_t>()];
    const auto length = v.is_object() ? v.find("byteLength") : v.end();
    if (!v.is_object() || length == v.end() || !length->is_number_unsigned()) return false;
    static const std::map<std::string, uint64_t> kComponents{{"SCALAR", 1}, {"VEC2", 2}, {"VEC3", 3}, {"VEC4", 4},
                                                             {"MAT2", 4},   {"MAT3", 9}, {"MAT4", 16}};
    const auto type = a.find("type");
    const auto component = a.find("componentType");
    if (type == a.end() || !type->is_string() || !kComponents.count(type->get<std::string>()) || component == a.end() ||
        !component->is_number_integer())
        return false;
    const int64_t c = component->get<int64_t>();
    const uint64_t bytes = c >= INT32_MIN && c <= INT32_MAX ? componentBytes(int(c)) : 0;
    if (bytes == 0) return false;
    const uint64_t element = bytes * kComponents.at(type->get<std::string>());
    const auto offsetIt = a.find("byteOffset");
    const uint64_t offset = offsetIt != a.end() && offsetIt->is_number_unsigned() ? offsetIt->get<uint64_t>() : 0;
    const uint64_t count = accessorCount(accessors, index), capacity = length->get<uint64_t>();
    return offset <= capacity && count <= (capacity - offset) / element;
}

// Every external file's URI, resolved (and refused when it reaches outside) before any
// file is opened; a buffer's byteLength against its file's size.
void checkFileUris(const std::string& file, const json& doc, ExternalFiles& files)
{
    for (const char* collection : {"buffers", "images"}) {
        const auto entries = doc.find(collection);
        if (entries == doc.end() || !entries->is_array()) continue;
        for (size_t i = 0; i < entries->size(); ++i) {
            const json& entry = (*entries)[i];
            const auto uri = entry.is_object() ? entry.find("uri") : entry.end();
            if (!entry.is_object() || uri == entry.end() || !uri->is_string()) continue;  // tinygltf reports it
            const std::string at = fmt::format("/{}/{}", collection, i);
            const std::string& text = uri->get_ref<const std::string&>();
            const std::filesystem::path path = files.add(at + "/uri", text);
            const auto length = entry.find("byteLength");
            if (std::string_view(collection) != "buffers" || length == entry.end() || !length->is_number_unsigned()) continue;
            const uint64_t byteLength = length->get<uint64_t>();
            if (path.empty()) {
                if (const int64_t decoded = dataUriBytes(text); decoded >= 0 && byteLength > uint64_t(decoded)) {
                    fail(file, at, fmt::format("byteLength {} exceeds the {} bytes its data URI holds", byteLength, decoded));
                }
                continue;
            }
            std::error_code ec;
            const uintmax_t size = std::filesystem::file_size(path, ec);
            if (!ec && byteLength > size) {
                fail(file, at, fmt::format("byteLength {} exceeds the {} bytes of its file '{}'", byteLength, size,
                                           core::shortText(text)));
            }
        }
    }
}

void checkPrimitives(const std::string& file, const json& doc, const GltfLoadOptions& options)
{
    const auto meshes = doc.find("meshes");
    if (meshes == doc.end() || !meshes->is_array()) return;
    const auto accessorsIt = doc.find("accessors");
    static const json kNone = json::array();
    const json& accessors = accessorsIt != doc.end() && accessorsIt->is_array() ? *accessorsIt : kNone;
    // The loader's own words for what it finds later (scene/gltf/Accessors.cpp, Geometry.cpp).
    const auto missing = [&](const std::string& at, const json& v) {
        fail(file, at, fmt::format("accessor {} does not exist ({} accessors)", core::shortJson(v), accessors.size()));
    };
    for (size_t m = 0; m < meshes->size(); ++m) {
        const json& mesh = (*meshes)[m];
        const auto primitives = mesh.is_object() ? mesh.find("primitives") : mesh.end();
        if (!mesh.is_object() || primitives == mesh.end() || !primitives->is_array()) continue;
        for (size_t p = 0; p < primitives->size(); ++p) {
            const json& primitive = (*primitives)[p];
            const std::string at = fmt::format("/meshes/{}/primitives/{}", m, p);
            const auto attributes = primitive.is_object() ? primitive.find("attributes") : primitive.end();
            if (!primitive.is_object() || attributes == primitive.end() || !attributes->is_object()) {
                fail(file, at, "has no \"attributes\" object (glTF 2.0 requires one, with POSITION for triangles)");
            }
            for (auto a = attributes->begin(); a != attributes->end(); ++a) {
                if (!validIndex(*a, accessors.size())) missing(at + "/attributes/" + core::shortText(a.key()), *a);
            }
            if (const auto position = attributes->find("POSITION"); position != attributes->end()) {
                const uint64_t vertices = accessorCount(accessors, *position);
                if (vertices > options.maxVertices && fitsItsView(doc, accessors, *position)) {
                    fail(file, fmt::format("/accessors/{}", position->dump()),
                         fmt::format("count {} exceeds {} (vertices left of the limit of {} per file)", vertices,
                                     options.maxVertices, options.maxVertices));
                }
            }
            if (const auto indices = primitive.find("indices"); indices != primitive.end()) {
                if (!validIndex(*indices, accessors.size())) missing(at + "/indices", *indices);
                // A triangle list has the fewest triangles for its indices (count / 3; a
                // strip or fan count - 2), so more than 3 t + 2 indices exceed t in any mode.
                const uint64_t count = accessorCount(accessors, *indices);
                const uint64_t most = 3 * options.maxTriangles + 2;
                if (count > most && fitsItsView(doc, accessors, *indices)) {
                    fail(file, fmt::format("/accessors/{}", indices->dump()),
                         fmt::format("count {} exceeds {} (indices for the {} triangles left of the limit of {} per file)",
                                     count, most, options.maxTriangles, options.maxTriangles));
                }
            }
        }
    }
}

} // namespace

void preflight(const std::string& file, const nlohmann::json& doc, ExternalFiles& files, const GltfLoadOptions& options)
{
    if (!doc.is_object()) return;  // tinygltf reports what it is
    checkFileUris(file, doc, files);
    checkPrimitives(file, doc, options);
}

} // namespace penumbra::scene::gltf
