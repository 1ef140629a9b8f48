#include "penumbra/scene/GltfWriter.h"

#include "penumbra/core/Error.h"
#include "penumbra/io/Png.h"
#include "penumbra/io/StagedFile.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <tiny_gltf.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cstddef>
#include <cstring>
#include <fstream>
#include <optional>
#include <sstream>

namespace fs = std::filesystem;

namespace penumbra::scene {
namespace {

// One interleaved vertex buffer view per mesh, read by three accessors.
static_assert(sizeof(Vertex) == 32 && offsetof(Vertex, position) == 0 && offsetof(Vertex, normal) == 12 &&
              offsetof(Vertex, uv) == 24);

// The double nearest the shortest decimal that reads back as `v`, so that the JSON
// says 0.1 rather than 0.10000000149011612; falls back to the exact value in the rare
// case where reading that decimal as a double and then as a float would round
// differently.
double shortDouble(float v)
{
    char text[32];
    const auto end = std::to_chars(text, text + sizeof(text), v).ptr;
    double d = 0.0;
    std::from_chars(text, end, d);
    return float(d) == v ? d : double(v);
}

std::vector<double> shortDoubles(const float* values, size_t count)
{
    std::vector<double> out(count);
    std::transform(values, values + count, out.begin(), shortDouble);
    return out;
}

// The local transform as translation and scale when it is only that (lossless and
// short), else as the matrix; nothing for the identity.
void setTransform(tinygltf::Node& node, const glm::mat4& m)
{
    const bool diagonal = m[0][1] == 0 && m[0][2] == 0 && m[1][0] == 0 && m[1][2] == 0 && m[2][0] == 0 && m[2][1] == 0;
    const bool affine = m[0][3] == 0 && m[1][3] == 0 && m[2][3] == 0 && m[3][3] == 1;
    if (!diagonal || !affine) {
        node.matrix = shortDoubles(&m[0][0], 16);  // both column-major
        return;
    }
    const glm::vec3 translation(m[3]), scale{m[0][0], m[1][1], m[2][2]};
    if (translation != glm::vec3(0.0f)) node.translation = shortDoubles(&translation.x, 3);
    if (scale != glm::vec3(1.0f)) node.scale = shortDoubles(&scale.x, 3);
}

class GltfBuilder {
public:
    GltfBuilder(const Scene& scene, const fs::path& path) : scene_(scene), path_(path)
    {
        model_.asset.version = "2.0";
        model_.asset.generator = "penumbra";
    }

    tinygltf::Model build()
    {
        for (const Texture& texture : scene_.textures) addTexture(texture);
        for (const Material& material : scene_.materials) addMaterial(material);
        for (const Mesh& mesh : scene_.meshes) addMesh(mesh);
        addNodes();
        if (!bytes_.empty()) {
            tinygltf::Buffer buffer;
            buffer.data = std::move(bytes_);
            model_.buffers.push_back(std::move(buffer));
        }
        return std::move(model_);
    }

private:
    [[noreturn]] void fail(const std::string& what) const { throw Error(fmt::format("{}: {}", path_.string(), what)); }

    // Appends to the one binary buffer at a 4-byte aligned offset (glTF requires
    // accessor offsets aligned to their component size); returns its buffer view.
    int addBufferView(const void* data, size_t size, size_t stride, int target)
    {
        const size_t offset = (bytes_.size() + 3) & ~size_t(3);
        bytes_.resize(offset + size);
        std::memcpy(bytes_.data() + offset, data, size);
        tinygltf::BufferView view;
        view.buffer = 0;
        view.byteOffset = offset;
        view.byteLength = size;
        view.byteStride = stride;
        view.target = target;
        model_.bufferViews.push_back(std::move(view));
        return int(model_.bufferViews.size() - 1);
    }

    int addAccessor(int view, size_t offset, int type, int componentType, size_t count)
    {
        tinygltf::Accessor accessor;
        accessor.bufferView = view;
        accessor.byteOffset = offset;
        accessor.type = type;
        accessor.componentType = componentType;
        accessor.count = count;
        model_.accessors.push_back(std::move(accessor));
        return int(model_.accessors.size() - 1);
    }

    // The image as a PNG in the binary buffer (a data URI would be discouraged in .glb).
    void addTexture(const Texture& texture)
    {
        const std::vector<uint8_t> png =
            io::encodePng(fmt::format("{}: texture '{}'", path_.string(), texture.name), texture.width, texture.height, texture.rgba);
        tinygltf::Image image;
        image.name = texture.name;
        image.mimeType = "image/png";
        image.bufferView = addBufferView(png.data(), png.size(), 0, 0);
        model_.images.push_back(std::move(image));
        tinygltf::Texture gltfTexture;
        gltfTexture.name = texture.name;
        gltfTexture.source = int(model_.images.size() - 1);
        model_.textures.push_back(std::move(gltfTexture));
    }

    void addMaterial(const Material& material)
    {
        tinygltf::Material m;
        m.name = material.name;
        m.pbrMetallicRoughness.baseColorFactor = shortDoubles(&material.baseColor.x, 4);
        // The engine shades every surface as a dielectric; glTF's default is metal.
        m.pbrMetallicRoughness.metallicFactor = 0.0;
        if (material.baseColorTexture != kNoTexture) {
            if (material.baseColorTexture < 0 || size_t(material.baseColorTexture) >= scene_.textures.size()) {
                fail(fmt::format("material '{}': base colour texture {} does not exist", material.name,
                                 material.baseColorTexture));
            }
            m.pbrMetallicRoughness.baseColorTexture.index = material.baseColorTexture;
        }
        m.alphaMode = material.alphaMode == AlphaMode::Mask ? "MASK" : material.alphaMode == AlphaMode::Blend ? "BLEND" : "OPAQUE";
        m.alphaCutoff = shortDouble(material.alphaCutoff);
        m.doubleSided = material.doubleSided;
        model_.materials.push_back(std::move(m));
    }

    void addMesh(const Mesh& mesh)
    {
        if (mesh.indices.empty() || mesh.indices.size() % 3 != 0) {
            fail(fmt::format("mesh '{}': {} indices, expected a positive multiple of 3", mesh.name, mesh.indices.size()));
        }
        const uint32_t maxIndex = *std::max_element(mesh.indices.begin(), mesh.indices.end());
        if (maxIndex >= mesh.vertices.size()) {
            fail(fmt::format("mesh '{}': index {} past its {} vertices", mesh.name, maxIndex, mesh.vertices.size()));
        }
        if (mesh.material >= scene_.materials.size()) {
            fail(fmt::format("mesh '{}': material {} does not exist", mesh.name, mesh.material));
        }
        const int vertexView = addBufferView(mesh.vertices.data(), mesh.vertices.size() * sizeof(Vertex), sizeof(Vertex), TINYGLTF_TARGET_ARRAY_BUFFER);
        const size_t count = mesh.vertices.size();
        tinygltf::Primitive primitive;
        primitive.mode = TINYGLTF_MODE_TRIANGLES;
        primitive.material = int(mesh.material);
        const int position = addAccessor(vertexView, offsetof(Vertex, position), TINYGLTF_TYPE_VEC3, TINYGLTF_COMPONENT_TYPE_FLOAT, count);
        // glTF requires POSITION's min and max, equal to the data: exact, not shortened.
        glm::vec3 lo(mesh.vertices[0].position), hi(lo);
        for (const Vertex& v : mesh.vertices) {
            lo = glm::min(lo, v.position);
            hi = glm::max(hi, v.position);
        }
        model_.accessors[size_t(position)].minValues = {lo.x, lo.y, lo.z};
        model_.accessors[size_t(position)].maxValues = {hi.x, hi.y, hi.z};
        primitive.attributes["POSITION"] = position;
        primitive.attributes["NORMAL"] = addAccessor(vertexView, offsetof(Vertex, normal), TINYGLTF_TYPE_VEC3, TINYGLTF_COMPONENT_TYPE_FLOAT, count);
        primitive.attributes["TEXCOORD_0"] = addAccessor(vertexView, offsetof(Vertex, uv), TINYGLTF_TYPE_VEC2, TINYGLTF_COMPONENT_TYPE_FLOAT, count);
        const int indexView = addBufferView(mesh.indices.data(), mesh.indices.size() * sizeof(uint32_t), 0, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
        primitive.indices = addAccessor(indexView, 0, TINYGLTF_TYPE_SCALAR, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, mesh.indices.size());
        tinygltf::Mesh gltfMesh;
        gltfMesh.name = mesh.name;
        gltfMesh.primitives.push_back(std::move(primitive));
        model_.meshes.push_back(std::move(gltfMesh));
    }

    // glTF node i is scene node i. A glTF node holds at most one mesh, so a scene node
    // with several instances keeps the first and gets one child per further instance.
    void addNodes()
    {
        const SceneGraph& graph = scene_.graph;
        std::vector<std::vector<uint32_t>> meshesOf(graph.size());
        for (const Instance& instance : scene_.instances) {
            if (instance.mesh >= scene_.meshes.size() || instance.node >= graph.size()) {
                fail(fmt::format("instance of mesh {} under node {}: no such mesh or node", instance.mesh, instance.node));
            }
            meshesOf[instance.node].push_back(instance.mesh);
        }
        model_.nodes.resize(graph.size());
        tinygltf::Scene gltfScene;
        for (uint32_t n = 0; n < graph.size(); ++n) {
            const Node& node = graph.node(n);
            model_.nodes[n].name = node.name;
            setTransform(model_.nodes[n], node.local);
            if (node.parent == kNoParent) gltfScene.nodes.push_back(int(n));
            else model_.nodes[size_t(node.parent)].children.push_back(int(n));
        }
        for (uint32_t n = 0; n < graph.size(); ++n) {
            for (size_t k = 0; k < meshesOf[n].size(); ++k) {
                if (k == 0) {
                    model_.nodes[n].mesh = int(meshesOf[n][0]);
                    continue;
                }
                tinygltf::Node extra;
                extra.name = fmt::format("{}#{}", graph.node(n).name, k);
                extra.mesh = int(meshesOf[n][k]);
                model_.nodes[n].children.push_back(int(model_.nodes.size()));
                model_.nodes.push_back(std::move(extra));
            }
        }
        model_.scenes.push_back(std::move(gltfScene));
        model_.defaultScene = 0;
    }

    const Scene& scene_;
    const fs::path& path_;
    tinygltf::Model model_;
    std::vector<unsigned char> bytes_;
};

// Percent-encodes all but RFC 3986's unreserved characters (tinygltf decodes URIs).
std::string encodeUri(const std::string& name)
{
    std::string out;
    for (const unsigned char c : name) {
        if (std::isalnum(c) || c == '-' || c == '.' || c == '_' || c == '~') out += char(c);
        else out += fmt::format("%{:02X}", c);
    }
    return out;
}

std::string lowercaseExtension(const fs::path& path)
{
    std::string extension = path.extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    return extension;
}

bool isBinaryGltf(const fs::path& path) { return lowercaseExtension(path) == ".glb"; }

void closeChecked(std::ofstream& out, const fs::path& target)
{
    out.close();
    if (!out) throw Error(fmt::format("{}: cannot write the file (disk full or permission denied?)", target.string()));
}

void writeGlb(tinygltf::Model& model, const fs::path& path)
{
    io::StagedFile file(path);
    std::ofstream out = file.openTemp();
    tinygltf::TinyGLTF gltf;
    if (!gltf.WriteGltfSceneToStream(&model, out, false, true)) {
        throw Error(fmt::format("{}: tinygltf could not serialise the scene", path.string()));
    }
    closeChecked(out, path);
    file.commit();
}

// The name of the buffer file written beside `<stem>.gltf` for `bytes`: `<stem>.<16 hex
// digits of the bytes' FNV-1a hash>.bin`. A new buffer gets a new name, so writing it never
// replaces the buffer the old .gltf references: the .gltf's rename alone switches from
// the old pair to the new one (with a fixed .bin name, a kill between the two renames
// would leave the new .bin beside the old .gltf, which would then fail to load). Equal
// bytes get the same name.
std::string bufferFileName(const std::string& stem, const std::vector<unsigned char>& bytes)
{
    uint64_t hash = 14695981039346656037ull;  // FNV-1a, 64-bit
    for (unsigned char b : bytes) hash = (hash ^ b) * 1099511628211ull;
    return fmt::format("{}.{:016x}.bin", stem, hash);
}

// Whether `name` is a buffer file this writer names for `stem` (above), or the plain
// `<stem>.bin` it wrote before.
bool ownBufferName(const std::string& name, const std::string& stem)
{
    if (name == stem + ".bin") return true;
    if (name.size() != stem.size() + 1 + 16 + 4 || name.rfind(stem + ".", 0) != 0 || !name.ends_with(".bin")) return false;
    return std::all_of(name.begin() + std::ptrdiff_t(stem.size() + 1), name.end() - 4,
                       [](unsigned char c) { return std::isxdigit(c) && !std::isupper(c); });
}

// tinygltf's stream writer embeds buffers as base64 and its file writer ignores write
// errors, so the JSON comes from tinygltf without the buffer, which is written here to
// its own file (bufferFileName), its URI added to the JSON. Once the .gltf is in place,
// the writer's other buffer files for this stem (the old .gltf's, or ones a killed run
// left) are removed.
void writeGltfWithBin(tinygltf::Model& model, const fs::path& path)
{
    std::vector<unsigned char> bytes;
    if (!model.buffers.empty()) bytes = std::move(model.buffers[0].data);
    model.buffers.clear();
    std::ostringstream text;
    tinygltf::TinyGLTF gltf;
    if (!gltf.WriteGltfSceneToStream(&model, text, false, false)) {
        throw Error(fmt::format("{}: tinygltf could not serialise the scene", path.string()));
    }
    nlohmann::json document = nlohmann::json::parse(text.str());

    const std::string stem = path.stem().string();
    const std::string binName = bytes.empty() ? std::string() : bufferFileName(stem, bytes);
    io::StagedFile json(path);
    std::optional<io::StagedFile> bin;
    if (!bytes.empty()) {
        bin.emplace(path.parent_path() / binName);
        document["buffers"] = nlohmann::json::array({{{"byteLength", bytes.size()}, {"uri", encodeUri(binName)}}});
        std::ofstream out = bin->openTemp();
        out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
        closeChecked(out, bin->target());
    }
    std::ofstream out = json.openTemp();
    out << document.dump(2) << '\n';
    closeChecked(out, path);
    // The .bin first (under its new name, beside the old pair), then the .gltf: either
    // the old pair or the new one is complete at every moment.
    if (bin) bin->commit();
    json.commit();
    std::error_code ec;
    const fs::path dir = path.has_parent_path() ? path.parent_path() : fs::path(".");
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
        const std::string name = it->path().filename().string();
        if (name != binName && ownBufferName(name, stem)) {
            std::error_code removeError;
            fs::remove(it->path(), removeError);  // best effort: a stale buffer is harmless
        }
    }
}

} // namespace

void checkGltfOutput(const fs::path& path)
{
    if (!isBinaryGltf(path) && lowercaseExtension(path) != ".gltf") {
        throw Error(fmt::format("{}: unknown glTF extension '{}', expected .gltf or .glb", path.string(),
                                path.extension().string()));
    }
    io::checkWritable(path);
}

void writeGltf(const Scene& scene, const fs::path& path)
{
    checkGltfOutput(path);
    tinygltf::Model model = GltfBuilder(scene, path).build();
    if (isBinaryGltf(path)) writeGlb(model, path);
    else writeGltfWithBin(model, path);
}

} // namespace penumbra::scene
