#pragma once
// Checks of a glTF file's JSON before tinygltf loads it: what tinygltf would report
// without a JSON path (or with a whole base64 payload in the message), what it would
// silently drop, and sizes that the loader's limits refuse anyway, before any buffer is
// read. Each failure is an AssetError "file: /json/path: what".
//
// - /buffers/i/uri, /images/i/uri: every file URI resolved and checked (scene/gltf/Uri.h)
//   before any file is opened, a URI that reaches outside the model refused;
// - /buffers/i: a byteLength beyond the bytes its data URI decodes to, or beyond its
//   external file's size;
// - /meshes/m/primitives/p: a primitive without `attributes` (required by glTF 2.0;
//   tinygltf dropped it and the file "validated" with no triangles), attribute and
//   `indices` references to accessors the file does not have;
// - /accessors/k: a POSITION accessor of more vertices, or an indices accessor of more
//   triangles, than the limits allow for the whole file (a 1 GB buffer was read whole
//   before the limit refused it).
#include "penumbra/scene/GltfLoader.h"
#include "scene/gltf/Uri.h"

#include <nlohmann/json.hpp>

#include <string>

namespace penumbra::scene::gltf {

// `files` receives every external file's URI.
void preflight(const std::string& file, const nlohmann::json& doc, ExternalFiles& files, const GltfLoadOptions& options);

} // namespace penumbra::scene::gltf
