#pragma once
// What changed since the frame before, as the versions of the render-graph states that
// passes depend on (graph::PassBuilder::dependsOn, RenderGraph::setState): the graph's
// executor keeps the results of a pass whose states and inputs kept their versions.
//
//   camera           render::kCameraState: the camera, and every instance that moved into,
//                    inside or out of its view
//   light<i>         render::lightState(i): the light, the scene's bounds, every instance
//                    that moved into, inside or out of a view its casters were last drawn
//                    in, and the camera too where the casters drawn follow it
//   lights           kLightTableState: what shading reads of every light (radiance, the
//                    culled lights' zero rows)
//
// A version only grows; a state whose inputs did not change keeps its version, and a
// pass that depends on it keeps its results.
#include "penumbra/render/Casters.h"
#include "penumbra/scene/Bvh.h"
#include "penumbra/scene/Scene.h"

#include <glm/glm.hpp>

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace penumbra::frame {

inline constexpr const char* kLightTableState = "lights";

// One frame's inputs, as the renderer holds them once the frame is set up.
struct FrameInputs {
    glm::mat4 cameraViewProj{1.0f};
    std::span<const scene::Light> lights;
    scene::Aabb sceneBounds;
    std::span<const uint32_t> movedInstances;  // indices into the scene's instances, moved since the last frame
    // Whether the casters a light's passes draw depend on the camera (receiver-mask or
    // occlusion culling, shadow-map focusing): a camera that moved then changes every light.
    bool castersFollowCamera = false;
    std::span<const std::byte> lightTable;  // what shading reads of the lights
};

class FrameChanges {
public:
    // Starts from the scene's instance boxes as they are; every state has version 1.
    explicit FrameChanges(const scene::Scene& scene);

    // The inputs of the next frame; `scene` holds the moved instances' new boxes.
    void update(const FrameInputs& inputs, const scene::Scene& scene);
    // The caster views a frame drew (render::Casters::takeDrawnViews): a light's are
    // replaced by the views of the frame that drew it last.
    void viewsDrawn(std::span<const render::CasterView> views);

    uint64_t camera() const { return camera_; }
    uint64_t light(size_t index) const { return index < lights_.size() ? lights_[index].version : 0; }
    uint64_t lightTable() const { return lightTable_; }

private:
    struct LightState {
        scene::Light light;
        std::vector<scene::Frustum> views;  // where its casters were drawn last
        uint64_t version = 1;
        bool seen = false;
    };
    std::vector<scene::Aabb> boxes_;  // each instance's world box as the last frame had it
    glm::mat4 cameraViewProj_{0.0f};
    bool cameraSeen_ = false;
    scene::Aabb sceneBounds_;
    std::vector<LightState> lights_;
    std::vector<std::byte> lightTableBytes_;
    uint64_t camera_ = 1;
    uint64_t lightTable_ = 1;
};

// Whether `box` may overlap `view` (false only when it lies wholly outside one of its
// planes). An empty box overlaps nothing.
bool boxMayBeInView(const scene::Aabb& box, const scene::Frustum& view);

} // namespace penumbra::frame
