#pragma once
// Reads a float OpenEXR file as the applications write V (apps/penumbra/VisibilityExr.h):
// its size and every FLOAT channel by name, rows top first; and writes one. For the tests
// that run the `penumbra` and `penumbra-viewer` executables.
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace penumbra::test {

struct Exr {
    int width = 0, height = 0;
    std::map<std::string, std::vector<float>> channels;
};

// Adds a GoogleTest failure for a channel that is not FLOAT.
Exr readExr(const std::filesystem::path& path);
// Writes `exr` (FLOAT channels, no compression), for tests that hand the executables files.
void writeExr(const std::filesystem::path& path, const Exr& exr);

} // namespace penumbra::test
