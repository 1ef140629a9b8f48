#pragma once
// Where this build tree keeps the files the tests and benchmarks read: the source tree,
// the test data, the penumbra executable, the engine library and the plugins. Only
// TestPaths.cpp sees the absolute paths (a header tests/CMakeLists.txt generates), so a
// clone in another folder compiles every test file as this one did and ccache serves them
// (top-level CMakeLists.txt); only that one small file is compiled again.
#include <filesystem>

namespace penumbra::test {

const std::filesystem::path& sourceDir();
// tests/data in the source tree.
const std::filesystem::path& testDataDir();
// The build tree's `penumbra` command.
const std::filesystem::path& penumbraExecutable();
// The build tree's `penumbra-viewer`.
const std::filesystem::path& viewerExecutable();
// The folder of the build tree's engine library.
const std::filesystem::path& engineLibraryDir();
// The build tree's technique plugins (what the build tree's engine searches).
const std::filesystem::path& buildPluginDir();
// The test plugins (tests/fixtures/plugins), and the folder of the one that a plugin of
// the same name shadows.
const std::filesystem::path& testPluginDir();
const std::filesystem::path& shadowedTestPluginDir();
// Test plugins whose loading crashes (SIGSEGV in the entry point or a constructor) or
// hangs: only the plugin scanner may meet them.
const std::filesystem::path& crashingTestPluginDir();
// The test plugins' sources (their shaders).
const std::filesystem::path& testPluginSourceDir();

} // namespace penumbra::test
