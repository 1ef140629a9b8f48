#pragma once
// glTF materials and their base-colour images -> Scene materials and RGBA8 textures,
// converted on first use: a material or image no loaded primitive uses cannot fail
// the load. glTF material i may land anywhere in Scene::materials (0 stays the default).
#include "scene/gltf/Document.h"
#include "scene/gltf/Images.h"
#include "scene/gltf/Uri.h"

#include <string_view>
#include <vector>

namespace penumbra::scene::gltf {

class MaterialTable {
public:
    MaterialTable(const Document& doc, const ImageDecoder& images, const ExternalFiles& files, Scene& scene);

    // The scene material for glTF material `material` (-1: the default material);
    // `element` is where it is referenced.
    uint32_t sceneMaterial(int material, std::string_view element);

private:
    int32_t sceneTexture(int texture, std::string_view element);
    std::string whyNoPixels(int image) const;

    const Document& doc_;
    const ImageDecoder& images_;
    const ExternalFiles& files_;
    Scene& scene_;
    std::vector<int64_t> materialOf_;  // glTF material -> scene material, -1 until converted
    std::vector<int64_t> textureOf_;   // glTF image -> scene texture, -1 until converted
};

} // namespace penumbra::scene::gltf
