#pragma once
// How the mouse and keys move the camera, as pure functions of scene::Camera so that they
// are tested without a window. Distances scale with the scene: a step is a fraction of
// the scene's radius (or of the distance to the target), never a fixed length, so a
// millimetre model and a city move alike.
#include "penumbra/config/RenderConfig.h"
#include "penumbra/scene/Scene.h"

namespace penumbra::viewer {

// Orbit: about the target. Fly: look around and move along the view. First person: the
// same, but moving on the horizontal plane (up stays up).
enum class CameraMode { Orbit, Fly, FirstPerson };

// Turns the camera about its target: yaw about the up axis, pitch raises the eye (degrees).
// The pitch stops 1 degree short of the poles, where the view would flip.
scene::Camera orbit(const scene::Camera& camera, float yawDeg, float pitchDeg);
// Moves position and target together in the view plane, by fractions of the target distance.
scene::Camera pan(const scene::Camera& camera, float right, float up);
// Moves towards the target by `factor` of the distance (0.5: half way; > 1 backs away);
// the distance stays above 1e-4 of `sceneRadius`.
scene::Camera dolly(const scene::Camera& camera, float factor, float sceneRadius);
// Fly / first person: looks around the position (yaw, pitch in degrees) and moves along
// the view (move.z), right (move.x) and up (move.y) by world distances; the target moves
// with it. `level`: forward and right stay in the horizontal plane (first person).
scene::Camera fly(const scene::Camera& camera, float yawDeg, float pitchDeg, const glm::vec3& move, bool level = false);

// World units per second for fly mode: a tenth of the scene's radius, times 2^speedExponent.
float flySpeed(float sceneRadius, float speedExponent);

// Camera tracks (targets under /camera/): the window either follows them or leaves the
// camera free; a free camera draws `config.camera` while the tracks stay in the config
// (Save writes them, `penumbra render` plays them).
enum class CameraFollow { Track, Free };
bool hasCameraTrack(const config::Animation& animation);
// The config as a free camera draws it: its camera tracks left out, every other track kept.
config::RenderConfig withoutCameraTracks(config::RenderConfig config);

} // namespace penumbra::viewer
