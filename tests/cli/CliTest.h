#pragma once
// What the tests of the `penumbra` command share (tests/cli/test_cli_<command>.cpp): the
// executable run as a user runs it, in a scratch folder of the test's own, and the configs
// and images those tests read and write.
#include "ExrFile.h"        // support/
#include "ScratchFolder.h"  // support/
#include "TestPaths.h"      // support/: the build tree's paths

#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace penumbra::test {

// What a run of the executable gave: its exit code (128 + the signal when one killed it)
// and what it wrote to stdout and stderr.
struct CliResult {
    int exitCode = -1;
    std::string out;
    std::string err;
};

inline bool has(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

// A PNG or JPEG file as 8-bit RGBA (width 0 when it cannot be read).
struct Rgba8Image {
    int width = 0, height = 0;
    std::vector<uint8_t> rgba;
    std::vector<int> at(int x, int y) const;
};
Rgba8Image readImage(const std::filesystem::path& file);

// The test plugins (tests/fixtures/plugins/) and the folder whose penumbra-dup.so
// shadows theirs.
std::string testPlugins();
std::string shadowedPlugins();
// PENUMBRA_PLUGIN_PATH naming the test plugins first, the shadowed folder second.
std::string pluginPath();

// A config of a box grid with a light using testgood with `shadow`'s extra keys, and one
// whose plugin exists nowhere (optional: "required": false); `extra` adds top-level keys.
std::string testGoodConfig(const std::string& shadow, const std::string& extra = "");

// One step of V_l's storage (R16_UNORM, shaders/common/visibility.glsl): figures of
// constant fills (0.25, 0.75) are exact up to it.
inline constexpr double kVStep = 1.0 / 65535.0;

// The flags that make testgood clearing V to 0.75 the reference of compare and bench.
inline const std::string kTestGoodReference = "--reference testgood --reference-set fill=0.75";

class Cli : public ScratchFolderTest {
protected:
    // Runs penumbra with `args` (already shell-quoted), `env` prepended as VAR=value pairs;
    // its stdout and stderr pass through stdout.txt and stderr.txt in the scratch folder.
    CliResult run(const std::string& args, const std::string& env = "") const;

    // A file of config/ and of tests/data/, shell-quoted.
    std::string config(const std::string& name) const;
    std::string data(const std::string& name) const;

    // `command` (all but -o) refuses an -o that names a file, or a folder whose parent is
    // missing, and changes neither.
    void expectBadOutputFoldersRefused(const std::string& command, const std::string& env) const;
};

} // namespace penumbra::test
