// libFuzzer target: the glTF loader as a config's "scene": {"gltf": FILE} runs it. The
// input is the file: a .glb when it starts with the GLB magic "glTF", else a .gltf (the
// loader tells them apart by the magic as well). Beside it lie a buffer and an image that
// its URIs may name (gltf.dict has their names).
//
// The contract under test: a file either loads into a Scene or is refused with a
// penumbra::Error (AssetError: the file and the JSON path). Any other exception, crash,
// sanitizer report, hang (-timeout) or runaway memory (-rss_limit_mb) is a finding.
//
// The loader's size limits are lowered here (a vertex, triangle and texel count that a
// small input can reach by its declared sizes): at the defaults a 100-byte file may ask
// for a legitimate 256 MiB image, which would only measure the allocator. The limits
// themselves are tested in tests/engine (GltfLoader tests).
#include "FuzzScratch.h"

#include "penumbra/core/Error.h"
#include "penumbra/io/Png.h"
#include "penumbra/scene/GltfLoader.h"

#include <spdlog/spdlog.h>

#include <cstring>
#include <vector>

namespace {

penumbra::fuzz::ScratchFolder* scratch = nullptr;

penumbra::scene::GltfLoadOptions fuzzOptions()
{
    penumbra::scene::GltfLoadOptions options;
    options.maxVertices = 1 << 16;
    options.maxTriangles = 1 << 16;
    options.maxInstances = 1 << 12;
    options.maxImageTexels = 256 * 256;
    options.maxTotalTexels = 1 << 18;
    options.maxBytesRead = 16 << 20;
    return options;
}

} // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***)
{
    scratch = new penumbra::fuzz::ScratchFolder();
    std::atexit([] { delete scratch; });
    // The loader's warnings (dropped content) would flood the fuzzer's output.
    spdlog::set_level(spdlog::level::off);
    // 256 bytes of a triangle list: 3 float3 positions then 3 uint16 indices, repeated.
    std::vector<uint8_t> buffer(256);
    const float positions[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const uint16_t indices[4] = {0, 1, 2, 0};
    for (size_t at = 0; at + sizeof positions + sizeof indices <= buffer.size(); at += sizeof positions + sizeof indices) {
        std::memcpy(buffer.data() + at, positions, sizeof positions);
        std::memcpy(buffer.data() + at + sizeof positions, indices, sizeof indices);
    }
    scratch->write("buffer.bin", buffer.data(), buffer.size());
    penumbra::io::writePng(scratch->path() / "texture.png", 2, 2, std::vector<uint8_t>(16, 200));
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
    const bool glb = size >= 4 && std::memcmp(data, "glTF", 4) == 0;
    const std::filesystem::path file = scratch->write(glb ? "scene.glb" : "scene.gltf", data, size);
    penumbra::scene::GltfLoadReport report;
    try {
        penumbra::scene::loadGltf(file, report, fuzzOptions());
    } catch (const penumbra::Error&) {
        // Refused with a message: the contract.
    }
    std::error_code ec;
    std::filesystem::remove(file, ec);  // so that a .glb input and a .gltf one never meet
    return 0;
}
