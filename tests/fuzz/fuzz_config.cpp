// libFuzzer target: the config reader as `penumbra render/compare/bench CONFIG` runs it.
// The input is the top-level config file; beside it lie files it may include (the fuzzer
// finds "include" and their names in config.dict). Each input is read with its includes,
// the first 64 variants of its sweep made and parsed into a RenderConfig, and their
// animation tracks evaluated at the frames render poses first and last.
//
// The contract under test: a config either loads or is refused with a penumbra::Error
// (the CLI's exit 1, naming the file and JSON path) whose message shows values shortened
// (core::shortJson): one longer than kMaxMessageBytes echoed a value whole and aborts, a
// finding (inputs are at most 8 KiB: run.sh). Any other exception escapes to
// libFuzzer as a finding (the CLI's exit 2, "internal error"), as do crashes, sanitizer
// reports, hangs (-timeout) and runaway memory (-rss_limit_mb).
#include "FuzzScratch.h"

#include "penumbra/config/Animation.h"
#include "penumbra/config/Document.h"
#include "penumbra/config/RenderConfig.h"
#include "penumbra/config/Sweep.h"
#include "penumbra/core/Error.h"

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>

namespace {

penumbra::fuzz::ScratchFolder* scratch = nullptr;

// A refusal names a file, a JSON path and what was expected, each value shortened to
// about core::kShownChars characters: far less than this.
constexpr size_t kMaxMessageBytes = 2048;

// Files an input may include: a complete config, a partial one, one that includes
// another (a chain), one that includes itself (a cycle), one that is not JSON, and two
// that fan out.
void writeIncludes(const penumbra::fuzz::ScratchFolder& folder)
{
    folder.write("base.json", R"({"scene": {"generator": "box-grid", "params": {"columns": 2, "rows": 2}},
 "camera": {"position": [15, 11, 17], "target": [1, 0, 0], "fov_y_deg": 45, "near": 0.05},
 "lights": [{"type": "spot", "position": [-9, 16, 7], "target": [1.5, 0, 0], "outer_cone_deg": 42,
             "inner_cone_deg": 34, "intensity": 900, "shadow": {"technique": "hard", "resolution": 256}}],
 "output": {"width": 64, "height": 48}, "frames": 1})");
    folder.write("lights.json", R"({"lights": [{"type": "directional", "direction": [0, -1, 0.2],
 "shadow": {"technique": "pcss"}}, {"type": "point", "position": [0, 3, 0], "intensity": 50}]})");
    folder.write("chain.json", R"({"include": "base.json", "camera": {"fov_deg": 70}})");
    folder.write("cycle.json", R"({"include": "cycle.json"})");
    folder.write("broken.json", R"({"scene": )");
    std::filesystem::create_directories(folder.path() / "sub");
    folder.write("sub/up.json", R"({"include": ["../base.json", "../lights.json"]})");
    // Includes fanning out: each file includes the next 40 times (an input that includes
    // fan.json 40 times asks for 64,000 loads; config::kMaxConfigFiles stops it).
    const auto forty = [](const std::string& name) {
        std::string list;
        for (int i = 0; i < 40; ++i) list += (i ? ", \"" : "\"") + name + "\"";
        return "{\"include\": [" + list + "]}";
    };
    folder.write("fan.json", forty("fan2.json"));
    folder.write("fan2.json", forty("base.json"));
}

// The tracks at the first, second and last frame, as render poses them (frame / fps): a
// frame rate or key time that passed the reader but breaks the evaluation is a finding.
void evaluateTracks(const penumbra::config::RenderConfig& config)
{
    for (const penumbra::config::AnimationTrack& track : config.animation.tracks) {
        for (const uint32_t frame : {0u, 1u, config.frames - 1}) {
            penumbra::config::evaluate(track, float(frame) / config.animation.fps);
        }
    }
}

} // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***)
{
    scratch = new penumbra::fuzz::ScratchFolder();
    std::atexit([] { delete scratch; });
    writeIncludes(*scratch);
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
    const std::filesystem::path file = scratch->write("config.json", data, size);
    try {
        const penumbra::config::ConfigDocument document = penumbra::config::loadDocument(file);
        // Variants are made one at a time; reading the sweep checks every entry (and
        // refuses larger products). The first few variants are made: each is a copy of
        // the document, and up to kMaxSweepCombinations of them take time, not memory.
        const penumbra::config::SweepVariants variants(document);
        for (size_t i = 0; i < variants.size() && i < 64; ++i) evaluateTracks(variants.variant(i).config);
    } catch (const penumbra::Error& e) {
        // Refused with a message: the contract.
        if (std::strlen(e.what()) > kMaxMessageBytes) {
            std::fprintf(stderr, "a message of %zu bytes: %.400s...\n", std::strlen(e.what()), e.what());
            std::abort();
        }
    }
    return 0;
}
