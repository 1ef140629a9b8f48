#pragma once
// From a config to what a frame draws: the scene its source describes, with the lights
// of a glTF file when the config says "lights": "scene".
#include "penumbra/config/RenderConfig.h"
#include "penumbra/scene/Scene.h"

#include <vector>

namespace penumbra::config {

// Builds the scene that the config's scene source describes (at its scale), and checks
// that the animation's node tracks name nodes of that scene. With "lights": "scene" it
// also fills config.lights from the glTF file's lights.
scene::Scene buildScene(RenderConfig& config);
// `fileLights` (optional) receives a glTF file's KHR_lights_punctual lights, placed and
// scaled with the scene.
scene::Scene buildScene(const SceneSource& source, std::vector<scene::Light>* fileLights = nullptr);

} // namespace penumbra::config
