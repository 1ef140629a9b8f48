#pragma once
// `penumbra generate city -o city.glb --set blocks=16`: writes a procedural scene
// (scene/Generators.h) as glTF: .gltf with a .bin beside it, or one .glb.
#include "CommandLine.h"

namespace penumbra::app {

Command addGenerateCommand(CLI::App& app);

} // namespace penumbra::app
