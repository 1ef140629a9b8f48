#pragma once
// glTF 2.0 scenes (.gltf with external or data-URI buffers, and .glb) through tinygltf:
// the default scene's node hierarchy (or every root node when the file names no
// scene) becomes the SceneGraph; each triangle primitive becomes one Mesh, instanced
// under every node that uses its glTF mesh; base colour, alpha mode and two-sidedness
// become Materials with RGBA8 textures; KHR_lights_punctual lights come back in the
// report with world-space position and direction. Every mesh passes repairMesh().
//
// Bad input throws AssetError "file: element: what", the element being the JSON
// pointer of the culprit ("Box.gltf: /accessors/3: count 4294967295 × 12 bytes exceeds
// buffer view 1 (288 bytes)"), values it echoes shortened. Sizes are checked against the
// buffers before anything is allocated, and the limits below bound what a file can make
// the loader allocate.
//
// Buffer and image URIs are RFC 3986 relative references, percent-decoded, resolved
// against the model's folder with links followed; before any file is opened, a URI is
// refused ("Box.gltf: /buffers/0/uri: "../x.bin": names /x.bin, outside the model's
// folder ...") when it has a scheme other than data: (file:, http:), is an absolute path,
// has a malformed escape or a NUL or control character, or names a file outside the
// model's own folder and GltfLoadOptions::allowedRoots. So a model reads only its own
// files, and no message quotes bytes of another. Every file is read as a regular file of
// bounded size (io/ReadFile.h): a FIFO or a device is refused, never waited on.
// What is dropped or ignored (points and lines, unknown optional extensions, cameras,
// skins, morph targets, animation channels that cannot play) is a warning or note in the
// report, never a silent omission. Animations are read into Scene::animations.
#include "penumbra/scene/MeshRepair.h"
#include "penumbra/scene/Scene.h"

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace penumbra::scene {

// What one file can make the loader allocate is bounded by these limits, each checked
// before the allocation it bounds.
// 16M vertices (512 MiB as Vertex) and 16M triangles (192 MiB of indices) per file,
// summed over the meshes loaded (an instanced mesh counts once), and 4M instances.
inline constexpr uint64_t kMaxGltfVertices = uint64_t(1) << 24;
inline constexpr uint64_t kMaxGltfTriangles = uint64_t(1) << 24;
inline constexpr uint64_t kMaxGltfInstances = uint64_t(1) << 22;
// Images are measured from their headers before decoding: 8192² texels each (256 MiB
// as RGBA8), 2^28 texels (1 GiB) for all the file's images together.
inline constexpr uint64_t kMaxGltfImageTexels = uint64_t(8192) * 8192;
inline constexpr uint64_t kMaxGltfTotalTexels = uint64_t(1) << 28;
// The .gltf/.glb and every external buffer and image file it reads, summed (tinygltf
// reads each file whole).
inline constexpr uint64_t kMaxGltfBytesRead = uint64_t(4) << 30;
// Objects and arrays nest at most this deep in a file's JSON (glTF itself nests 6
// levels; `extras` and `extensions` hold anything). Checked by a scan of the text before
// tinygltf parses it: its conversion of `extras` recurses per level, and ~15,000 levels
// overflowed the stack.
inline constexpr int kMaxGltfNesting = 256;

struct GltfLoadOptions {
    uint64_t maxVertices = kMaxGltfVertices;
    uint64_t maxTriangles = kMaxGltfTriangles;
    uint64_t maxInstances = kMaxGltfInstances;
    uint64_t maxImageTexels = kMaxGltfImageTexels;
    uint64_t maxTotalTexels = kMaxGltfTotalTexels;
    uint64_t maxBytesRead = kMaxGltfBytesRead;
    // Folders besides the model's own whose files its URIs may name (a config's
    // scene.allowed_roots, the command line's --allow-root); relative ones are taken from
    // the working folder.
    std::vector<std::filesystem::path> allowedRoots;
    RepairOptions repair;
};

struct GltfLight {
    std::string name;
    uint32_t node = 0;  // the scene graph node that carries it
    // World space at load. glTF's units carry over: candela for spot and point lights,
    // lux for directional ones; inner/outer cone angles in degrees.
    Light light;
};

// One per Scene::meshes entry, in the same order.
struct GltfMeshReport {
    std::string element;  // "/meshes/2/primitives/1"
    RepairReport repair;
};

struct GltfLoadReport {
    std::vector<GltfLight> lights;
    std::vector<GltfMeshReport> meshes;
    // Dropped or suspicious content ("file: element: what"), also logged as warnings.
    std::vector<std::string> warnings;
    // Features ignored on purpose (cameras, skins, morph targets), also logged.
    std::vector<std::string> notes;
};

// Loads `file` (.gltf or .glb, told apart by the GLB magic) into a new Scene. The
// report is filled as the load goes, so after a throw it holds what came before.
Scene loadGltf(const std::filesystem::path& file, GltfLoadReport& report, const GltfLoadOptions& options = {});

} // namespace penumbra::scene
