#pragma once
// The GNU build id of the engine library (the linker's hash of its code and data): what
// tells one build of the engine, and of the glslang linked into it, from another.
#include <string>

namespace penumbra::core {

// Hexadecimal; empty when the library carries none (linked without --build-id).
const std::string& engineBuildId();

} // namespace penumbra::core
