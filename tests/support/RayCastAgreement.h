#pragma once
// A light's visibility image checked against rays from the light (RayCast.h), with the
// same semantics as a shadow map: a pixel's surface point p is lit when the first
// surface the light's ray towards p meets is p itself, shadowed when something nearer
// blocks it. A shadow map answers from texels (and a filtered one from several), so
// near any edge in the light's view its answer may come from the neighbouring surface:
// rays aimed at p shifted sideways by up to `bandTexels` shadow-map texels (8 directions,
// at half and full distance) must all give p's answer (lit: meet p's tangent plane within
// two texels of depth) for the pixel to count; pixels that fail this are near a shadow or
// silhouette edge as seen from the light and are left out. So are surfaces facing away
// from the light or within ~6 degrees of grazing (N.L < 0.1): shading weights the light
// by max(N.L, 0), so V does not reach the image there, and a hard shadow map with the
// slope bias that prevents acne may leak behind casters seen at grazing angles.
#include "RayCast.h"

#include "penumbra/render/Projection.h"
#include "penumbra/scene/Scene.h"

#include <cstdint>
#include <string>
#include <vector>

namespace penumbra::test {

enum class RayClass { Skipped, NearEdge, Lit, Shadowed };

class LightRayClassifier {
public:
    // `frusta` and `resolution` are the technique's shadow map (render::shadowFrusta and
    // texels per face side): they set the world size of a texel at each point.
    LightRayClassifier(const scene::Scene& scene, const scene::Light& light, std::vector<render::LightFrustum> frusta,
                       uint32_t resolution);

    RayClass classify(const glm::dvec3& p, const glm::dvec3& normal, double bandTexels) const;

private:
    RayCaster caster_;
    scene::Light light_;
    std::vector<render::LightFrustum> frusta_;
    uint32_t resolution_;
    double farWorld_;  // a directional light's rays start this far back
};

// What a rendered frame gives back, one light's visibility included.
struct FrameImages {
    const std::vector<float>& positions;  // 4 floats per pixel, w = 0 where no geometry
    const std::vector<float>& normals;    // 4 floats per pixel
    const std::vector<float>& visibility; // 1 float per pixel
    uint32_t width = 0;
    uint32_t height = 0;
};

struct AgreementOptions {
    uint32_t stride = 2;       // every stride-th pixel in x and y
    double bandTexels = 2.0;   // see the file comment
    float tolerance = 0.0f;    // |V - expected| allowed
    std::string label;         // prefixed to failure messages ("light 0")
};

struct RayCastAgreement {
    size_t surelyShadowed = 0;
    size_t surelyLit = 0;
    size_t mismatches = 0;
};

// Reports the first ten mismatches as test failures (ADD_FAILURE) and counts them all.
RayCastAgreement compareWithRayCast(const LightRayClassifier& classifier, const FrameImages& frame,
                                    const AgreementOptions& options = {});

} // namespace penumbra::test
