// libFuzzer target: the glTF loader as a config's "scene": {"gltf": FILE} runs it. The
// input is the file: a .glb when it starts with the GLB magic "glTF", else a .gltf (the
// loader tells them apart by the magic as well), in a folder model/. Beside it lie what
// its URIs may name (gltf.dict has their names): a buffer and an image, FIFOs named like
// them (pipe.bin, pipe.png), and a link (link.bin) to secret.bin, a valid buffer outside
// the model's folder (../secret.bin).
//
// The contract under test: a file either loads into a Scene or is refused with a
// penumbra::Error (AssetError: the file and the JSON path), without ever opening
// secret.bin (watched with inotify) or quoting its bytes in a message. Any other
// exception, crash, sanitizer report, hang (-timeout: a FIFO opened and read) or runaway
// memory (-rss_limit_mb) is a finding.
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
#include <sys/inotify.h>
#include <sys/stat.h>

#include <cstdio>
#include <cstring>
#include <vector>

namespace {

penumbra::fuzz::ScratchFolder* scratch = nullptr;
// What secret.bin starts with: no message may hold it.
constexpr std::string_view kSecret = "PENUMBRA-FUZZ-SECRET";
int secretWatch = -1;  // inotify: an event is an open or a read of secret.bin

[[noreturn]] void finding(const std::string& what)
{
    std::fprintf(stderr, "penumbra fuzz: %s\n", what.c_str());
    std::abort();
}

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
    std::filesystem::create_directory(scratch->path() / "model");
    scratch->write("model/buffer.bin", buffer.data(), buffer.size());
    penumbra::io::writePng(scratch->path() / "model" / "texture.png", 2, 2, std::vector<uint8_t>(16, 200));
    std::vector<uint8_t> secret(kSecret.begin(), kSecret.end());
    secret.insert(secret.end(), buffer.begin(), buffer.end());
    const std::filesystem::path secretFile = scratch->write("secret.bin", secret.data(), secret.size());
    std::filesystem::create_symlink(secretFile, scratch->path() / "model" / "link.bin");
    for (const char* fifo : {"model/pipe.bin", "model/pipe.png"}) {
        if (::mkfifo((scratch->path() / fifo).c_str(), 0600) != 0) finding("cannot make the FIFOs");
    }
    secretWatch = ::inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
    if (secretWatch < 0 || ::inotify_add_watch(secretWatch, secretFile.c_str(), IN_OPEN | IN_ACCESS) < 0) {
        finding("cannot watch secret.bin");
    }
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
    const bool glb = size >= 4 && std::memcmp(data, "glTF", 4) == 0;
    // libFuzzer learns the strings the target compares (kSecret below) and writes them
    // into inputs: a message may quote the input itself, so the secret's bytes in a
    // message are a finding only when the input does not hold them.
    const std::string_view input(reinterpret_cast<const char*>(data), size);
    const bool inputHoldsSecret = input.find(kSecret) != std::string_view::npos;
    const auto quotesSecret = [&](std::string_view text) {
        return !inputHoldsSecret && text.find(kSecret) != std::string_view::npos;
    };
    const std::filesystem::path file = scratch->write(glb ? "model/scene.glb" : "model/scene.gltf", data, size);
    penumbra::scene::GltfLoadReport report;
    try {
        penumbra::scene::loadGltf(file, report, fuzzOptions());
    } catch (const penumbra::Error& e) {
        // Refused with a message: the contract, if it quotes nothing of a file outside.
        if (quotesSecret(e.what())) finding("a message quotes secret.bin");
    }
    for (const auto* lines : {&report.warnings, &report.notes}) {
        for (const std::string& line : *lines) {
            if (quotesSecret(line)) finding("a warning quotes secret.bin");
        }
    }
    char events[4096];
    if (::read(secretWatch, events, sizeof events) > 0) finding("the loader opened secret.bin, outside the model's folder");
    std::error_code ec;
    std::filesystem::remove(file, ec);  // so that a .glb input and a .gltf one never meet
    return 0;
}
