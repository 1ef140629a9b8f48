#include "scene/gltf/Materials.h"

#include "penumbra/core/ShortText.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace penumbra::scene::gltf {

MaterialTable::MaterialTable(const Document& doc, const ImageDecoder& images, const ExternalFiles& files, Scene& scene)
    : doc_(doc), images_(images), files_(files), scene_(scene),
      materialOf_(doc.model.materials.size(), -1), textureOf_(doc.model.images.size(), -1)
{
}

uint32_t MaterialTable::sceneMaterial(int index, std::string_view element)
{
    if (index < 0) return 0;
    if (size_t(index) >= materialOf_.size()) {
        doc_.fail(element, fmt::format("material {} does not exist ({} materials)", index, materialOf_.size()));
    }
    if (materialOf_[size_t(index)] >= 0) return uint32_t(materialOf_[size_t(index)]);

    const tinygltf::Material& source = doc_.model.materials[size_t(index)];
    const std::string path = fmt::format("/materials/{}", index);
    Material material;
    material.name = source.name.empty() ? fmt::format("material{}", index) : source.name;

    const std::vector<double>& factor = source.pbrMetallicRoughness.baseColorFactor;
    if (factor.size() != 4 || !std::all_of(factor.begin(), factor.end(), [](double x) { return std::isfinite(x); })) {
        doc_.fail(path + "/pbrMetallicRoughness/baseColorFactor", "must be 4 finite numbers");
    }
    material.baseColor = glm::vec4(float(factor[0]), float(factor[1]), float(factor[2]), float(factor[3]));

    if (source.alphaMode == "OPAQUE") {
        material.alphaMode = AlphaMode::Opaque;
    } else if (source.alphaMode == "MASK") {
        material.alphaMode = AlphaMode::Mask;
    } else if (source.alphaMode == "BLEND") {
        material.alphaMode = AlphaMode::Blend;
    } else {
        doc_.fail(path + "/alphaMode", fmt::format("'{}' is not OPAQUE, MASK or BLEND", core::shortText(source.alphaMode)));
    }
    if (!std::isfinite(source.alphaCutoff) || source.alphaCutoff < 0.0) {
        doc_.fail(path + "/alphaCutoff", fmt::format("must be a number >= 0, got {}", source.alphaCutoff));
    }
    material.alphaCutoff = float(source.alphaCutoff);
    material.doubleSided = source.doubleSided;

    const tinygltf::TextureInfo& texture = source.pbrMetallicRoughness.baseColorTexture;
    if (texture.index >= 0) {
        const std::string texturePath = path + "/pbrMetallicRoughness/baseColorTexture";
        material.baseColorTexture = sceneTexture(texture.index, texturePath);
        if (texture.texCoord != 0) {
            doc_.warn(texturePath, fmt::format("uses TEXCOORD_{}; penumbra reads TEXCOORD_0 only", texture.texCoord));
        }
    }
    scene_.materials.push_back(std::move(material));
    materialOf_[size_t(index)] = int64_t(scene_.materials.size() - 1);
    return uint32_t(scene_.materials.size() - 1);
}

int32_t MaterialTable::sceneTexture(int index, std::string_view element)
{
    const tinygltf::Model& model = doc_.model;
    if (size_t(index) >= model.textures.size()) {
        doc_.fail(element, fmt::format("texture {} does not exist ({} textures)", index, model.textures.size()));
    }
    const int image = model.textures[size_t(index)].source;
    if (image < 0) {
        // KHR_texture_basisu and EXT_texture_webp name their image in an extension only.
        doc_.warn(fmt::format("/textures/{}", index), "has no source image penumbra can decode; base colour texture ignored");
        return kNoTexture;
    }
    if (size_t(image) >= textureOf_.size()) {
        doc_.fail(fmt::format("/textures/{}/source", index),
                  fmt::format("image {} does not exist ({} images)", image, textureOf_.size()));
    }
    if (textureOf_[size_t(image)] >= 0) return int32_t(textureOf_[size_t(image)]);

    const tinygltf::Image& source = model.images[size_t(image)];
    const std::string path = fmt::format("/images/{}", image);
    if (source.image.empty()) doc_.fail(path, whyNoPixels(image));
    // The image loader (Images.cpp) always produces RGBA8.
    const uint64_t bytes = uint64_t(source.width) * uint64_t(source.height) * 4;
    if (source.width <= 0 || source.height <= 0 || source.component != 4 || source.bits != 8 || source.image.size() != bytes) {
        doc_.fail(path, fmt::format("decoded to {}×{}×{} channels of {} bits, {} bytes; expected RGBA8", source.width,
                                    source.height, source.component, source.bits, source.image.size()));
    }
    Texture texture;
    texture.name = source.name.empty() ? (source.uri.empty() ? fmt::format("image{}", image) : source.uri) : source.name;
    texture.width = uint32_t(source.width);
    texture.height = uint32_t(source.height);
    texture.rgba = source.image;
    scene_.textures.push_back(std::move(texture));
    textureOf_[size_t(image)] = int64_t(scene_.textures.size() - 1);
    return int32_t(scene_.textures.size() - 1);
}

std::string MaterialTable::whyNoPixels(int image) const
{
    if (auto it = images_.failures.find(image); it != images_.failures.end()) return it->second;
    const tinygltf::Image& source = doc_.model.images[size_t(image)];
    // tinygltf keeps the uri of an external file it could not load (and only then).
    if (source.uri.empty()) return "has no image data";
    if (std::string failure = files_.failure(fmt::format("/images/{}/uri", image)); !failure.empty()) return failure;
    // Only a data: URI is never asked for as a file (scene/gltf/Uri.h).
    return fmt::format("its data: URI \"{}\" is of a media type tinygltf does not decode (it decodes image/png, "
                       "image/jpeg, image/bmp and image/gif)",
                       core::shortText(source.uri));
}

} // namespace penumbra::scene::gltf
