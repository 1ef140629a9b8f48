#pragma once
// A parsed glTF file as the loader's parts see it: tinygltf's model, the file name for
// messages, the options and the report. Every check says "file: element: what".
#include "penumbra/scene/GltfLoader.h"

#include <tiny_gltf.h>

#include <string>
#include <string_view>

namespace penumbra::scene::gltf {

struct Document {
    const tinygltf::Model& model;
    std::string file;
    const GltfLoadOptions& options;
    GltfLoadReport& report;

    // Throws AssetError "file: element: what".
    [[noreturn]] void fail(std::string_view element, std::string_view what) const;
    // Logs and records "file: element: what".
    void warn(std::string_view element, std::string_view what) const;
    void note(std::string_view element, std::string_view what) const;
};

// tinygltf's messages end in newlines and may hold several lines: one line, '; '-joined.
std::string oneLine(std::string text);

} // namespace penumbra::scene::gltf
