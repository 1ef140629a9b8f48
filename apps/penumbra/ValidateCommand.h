#pragma once
// `penumbra validate file`: a glTF file (.gltf, .glb) loaded and repaired, with what it
// holds and what was repaired; or a config (.json) checked without rendering: includes,
// every sweep variant, the scene it builds, node tracks, and each light's plugin with its
// parameters.
#include "CommandLine.h"

namespace penumbra::app {

// `verbose` (-v): the glTF loader's warnings are logged as well as listed.
Command addValidateCommand(CLI::App& app, const bool& verbose);

} // namespace penumbra::app
