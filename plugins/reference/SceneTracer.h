#pragma once
// The scene in Embree (3.13): one BVH per mesh, instanced by a top-level scene with one
// instance per scene instance (the same sharing as the glTF scene), refitted when
// instances move. Shadow rays return the transmittance along a segment: 0 when an
// opaque surface blocks it, else the product of (1 - alpha) over the translucent
// (alphaMode BLEND) surfaces it crosses; alpha-masked (MASK) surfaces let it pass where
// the base colour's alpha at the hit is below the cutoff, as the raster path cuts holes.
// Translucency is handled in Embree occlusion filter callbacks that collect crossings
// and reject them so that traversal goes on.
#include "penumbra/core/Digest.h"
#include "penumbra/scene/Scene.h"

#include <embree3/rtcore.h>
#include <glm/glm.hpp>

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

namespace penumbra::reference {

// Sets flush-to-zero and denormals-are-zero for its lifetime (PLATFORM.md: Embree wants
// them in every thread that calls it), restoring the thread's previous mode.
class DenormalsAreZero {
public:
    DenormalsAreZero();
    ~DenormalsAreZero();
    DenormalsAreZero(const DenormalsAreZero&) = delete;
    DenormalsAreZero& operator=(const DenormalsAreZero&) = delete;

private:
    unsigned saved_ = 0;
};

struct SurfaceAlpha;  // SceneTracer.cpp: a mesh's material as the filter callbacks see it

// A translucent surface a shadow ray crossed.
struct Crossing {
    uint32_t instance = 0;
    float distance = 0.0f;       // along the ray
    float transmittance = 1.0f;  // 1 - alpha
};

// Per-thread scratch for SceneTracer::transmittance, reused between rays so that a ray
// allocates nothing.
struct RayScratch {
    std::vector<Crossing> crossings;
};

class SceneTracer {
public:
    // Builds the BVHs. `scene` must outlive the tracer (the filter callbacks read its
    // meshes, materials and textures). Throws penumbra::Error naming Embree's error.
    explicit SceneTracer(const scene::Scene& scene);
    ~SceneTracer();
    SceneTracer(const SceneTracer&) = delete;
    SceneTracer& operator=(const SceneTracer&) = delete;

    // The scene's nodes moved: `instances` have new world transforms (in the scene).
    void refit(std::span<const uint32_t> instances);

    // Transmittance of the segment origin + t * direction, t in [0, length] (length may
    // be +inf), in [0, 1]. `direction` is unit. Thread-safe; call with
    // DenormalsAreZero in effect. `sameSurface` (world units): crossings of one instance
    // closer than this count once, since Embree may report a hit twice (a ray through a
    // shared edge, or spatial splits).
    float transmittance(const glm::vec3& origin, const glm::vec3& direction, float length, float sameSurface,
                        RayScratch& scratch) const;

    // A 128-bit digest of everything in the scene that shadow rays see: every mesh's
    // triangles and texture coordinates, the alpha mode, cutoff, alpha and alpha texture
    // of its material, and every instance's mesh and world transform. Two scenes with
    // equal digests cast the same shadows.
    core::Hash128 geometryDigest() const { return digest_; }

    // The world-space radius of the scene's bounds (for epsilons relative to its scale).
    float sceneRadius() const { return sceneRadius_; }

private:
    void attachInstance(uint32_t instance);
    void setTransform(uint32_t instance);
    void updateDigest();
    void checkDevice(const char* what) const;

    const scene::Scene& scene_;
    RTCDevice device_ = nullptr;
    RTCScene top_ = nullptr;
    std::vector<RTCScene> meshScenes_;  // per mesh; null for a mesh without triangles
    std::vector<std::unique_ptr<SurfaceAlpha>> surfaces_;  // per mesh: what the filters read
    std::vector<core::Hash128> meshDigests_;
    core::Hash128 digest_{};
    float sceneRadius_ = 0.0f;
};

} // namespace penumbra::reference
