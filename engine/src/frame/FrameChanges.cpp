#include "penumbra/frame/FrameChanges.h"

#include <algorithm>
#include <cstring>

namespace penumbra::frame {

bool boxMayBeInView(const scene::Aabb& box, const scene::Frustum& view)
{
    if (box.empty()) return false;
    for (uint32_t p = 0; p < view.planeCount; ++p) {
        const glm::vec4& plane = view.planes[p];
        // The corner furthest along the plane's inward normal: if even it is outside, all are.
        const glm::vec3 far{plane.x >= 0.0f ? box.max.x : box.min.x, plane.y >= 0.0f ? box.max.y : box.min.y,
                            plane.z >= 0.0f ? box.max.z : box.min.z};
        if (glm::dot(glm::vec3(plane), far) + plane.w < 0.0f) return false;
    }
    return true;
}

namespace {

bool sameBounds(const scene::Aabb& a, const scene::Aabb& b) { return a.min == b.min && a.max == b.max; }

// Whether the instance's box before or after its move may lie in the view.
bool moveSeenBy(const scene::Aabb& before, const scene::Aabb& after, const scene::Frustum& view)
{
    return boxMayBeInView(before, view) || boxMayBeInView(after, view);
}

} // namespace

FrameChanges::FrameChanges(const scene::Scene& scene)
{
    boxes_.reserve(scene.instances.size());
    for (const scene::Instance& instance : scene.instances) boxes_.push_back(instance.worldBounds);
    sceneBounds_ = scene.bounds();
}

void FrameChanges::update(const FrameInputs& inputs, const scene::Scene& scene)
{
    // The camera: its matrix, and what moved in its view.
    bool cameraChanged = !cameraSeen_ || inputs.cameraViewProj != cameraViewProj_;
    if (!cameraChanged && !inputs.movedInstances.empty()) {
        const scene::Frustum view = scene::frustumFromViewProj(inputs.cameraViewProj);
        for (uint32_t i : inputs.movedInstances) {
            if (i >= boxes_.size() || i >= scene.instances.size()) continue;
            if (moveSeenBy(boxes_[i], scene.instances[i].worldBounds, view)) {
                cameraChanged = true;
                break;
            }
        }
    }
    if (cameraChanged && cameraSeen_) ++camera_;
    cameraSeen_ = true;
    cameraViewProj_ = inputs.cameraViewProj;

    const bool boundsChanged = !sameBounds(inputs.sceneBounds, sceneBounds_);
    sceneBounds_ = inputs.sceneBounds;
    lights_.resize(inputs.lights.size());
    for (size_t l = 0; l < inputs.lights.size(); ++l) {
        LightState& state = lights_[l];
        bool changed = boundsChanged || (inputs.castersFollowCamera && cameraChanged) ||
                       (state.seen && !(state.light == inputs.lights[l]));
        for (uint32_t i : inputs.movedInstances) {
            if (changed) break;
            if (i >= boxes_.size() || i >= scene.instances.size()) continue;
            changed = std::any_of(state.views.begin(), state.views.end(), [&](const scene::Frustum& view) {
                return moveSeenBy(boxes_[i], scene.instances[i].worldBounds, view);
            });
        }
        if (changed && state.seen) ++state.version;
        state.seen = true;
        state.light = inputs.lights[l];
    }
    for (uint32_t i : inputs.movedInstances)
        if (i < boxes_.size() && i < scene.instances.size()) boxes_[i] = scene.instances[i].worldBounds;

    const bool tableChanged = inputs.lightTable.size() != lightTableBytes_.size() ||
                              std::memcmp(inputs.lightTable.data(), lightTableBytes_.data(), lightTableBytes_.size()) != 0;
    if (tableChanged) {
        if (!lightTableBytes_.empty()) ++lightTable_;
        lightTableBytes_.assign(inputs.lightTable.begin(), inputs.lightTable.end());
    }
}

void FrameChanges::viewsDrawn(std::span<const render::CasterView> views)
{
    std::vector<bool> replaced(lights_.size(), false);
    for (const render::CasterView& view : views) {
        if (view.light >= lights_.size()) continue;
        if (!replaced[view.light]) {
            lights_[view.light].views.clear();
            replaced[view.light] = true;
        }
        lights_[view.light].views.push_back(scene::frustumFromViewProj(view.viewProj));
    }
}

} // namespace penumbra::frame
