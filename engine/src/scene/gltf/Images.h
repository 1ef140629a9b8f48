#pragma once
// tinygltf decodes every image while it parses. This image loader, installed with
// TinyGLTF::SetImageLoader, bounds that work and never fails the parse: it reads the
// image's size from its header first (refusing more than the texel limits before any
// pixel is allocated), decodes through tinygltf's own loader (stb_image) into RGBA8,
// and records why an image could not be decoded, so that only images a material
// really uses can fail the load, naming the image.
#include <tiny_gltf.h>

#include <cstdint>
#include <map>
#include <string>

namespace penumbra::scene::gltf {

struct ImageDecoder {
    const tinygltf::Model* model = nullptr;  // the model being parsed (for buffer-view images)
    uint64_t maxImageTexels = 0;
    uint64_t texelsLeft = 0;                 // of the budget for all the file's images
    std::map<int, std::string> failures;     // image index -> why it has no pixels

    // Installs the loader on `loader`; `this` must outlive the parse.
    void install(tinygltf::TinyGLTF& loader);
};

} // namespace penumbra::scene::gltf
