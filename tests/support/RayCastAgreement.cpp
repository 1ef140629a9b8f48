#include "RayCastAgreement.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

namespace penumbra::test {

LightRayClassifier::LightRayClassifier(const scene::Scene& scene, const scene::Light& light,
                                       std::vector<render::LightFrustum> frusta, uint32_t resolution)
    : caster_(scene), light_(light), frusta_(std::move(frusta)), resolution_(resolution),
      farWorld_(4.0 * scene.bounds().radius())
{
}

RayClass LightRayClassifier::classify(const glm::dvec3& p, const glm::dvec3& normal, double bandTexels) const
{
    if (glm::length(normal) == 0.0) return RayClass::Skipped;
    const glm::dvec3 n = glm::normalize(normal);
    const bool directional = light_.type == scene::LightType::Directional;
    const glm::dvec3 lightPos = directional ? p - farWorld_ * glm::dvec3(glm::normalize(light_.direction))
                                            : glm::dvec3(light_.position);
    const glm::dvec3 toLight = glm::normalize(lightPos - p);
    if (glm::dot(n, toLight) < 0.1) return RayClass::Skipped;

    // The frustum that maps p (the only one, or p's cube face).
    size_t face = 0;
    if (frusta_.size() == 6) {
        const glm::dvec3 d = p - glm::dvec3(light_.position), a = glm::abs(d);
        face = a.x >= a.y && a.x >= a.z ? (d.x > 0 ? 0 : 1) : a.y >= a.z ? (d.y > 0 ? 2 : 3) : (d.z > 0 ? 4 : 5);
    }
    const render::LightFrustum& f = frusta_.at(face);
    const glm::vec4 clip = f.viewProj * glm::vec4(glm::vec3(p), 1.0f);
    if (clip.w <= 0.0f) return RayClass::Skipped;
    const glm::vec2 uv = glm::vec2(clip) / clip.w * 0.5f + 0.5f;
    // Outside the map V is 1 by contract; stay clear of its border.
    if (glm::any(glm::lessThan(uv, glm::vec2(0.01f))) || glm::any(glm::greaterThan(uv, glm::vec2(0.99f))))
        return RayClass::Skipped;
    // World size of one texel at p: 2 / (P · R) per unit of view depth for a perspective
    // frustum, per world unit for an orthographic one; the larger axis (P the smaller of
    // proj[0][0] and proj[1][1]: an orthographic box need not be square).
    const double viewDepth = directional ? 1.0 : -double((f.view * glm::vec4(glm::vec3(p), 1.0f)).z);
    const double scale = std::min(std::abs(double(f.proj[0][0])), std::abs(double(f.proj[1][1])));
    const double texel = 2.0 * viewDepth / (scale * resolution_);

    const double dist = glm::length(lightPos - p);
    const glm::dvec3 dirToP = (p - lightPos) / dist;
    const double firstHit = caster_.closestHit(lightPos, dirToP);
    const double tolerance = 2.0 * texel;
    // Sideways shifts of the aim point, across the light's ray.
    const glm::dvec3 s1 = glm::normalize(
        glm::cross(dirToP, std::abs(dirToP.y) < 0.9 ? glm::dvec3(0, 1, 0) : glm::dvec3(1, 0, 0)));
    const glm::dvec3 s2 = glm::cross(dirToP, s1);
    for (double radius : {0.5 * bandTexels, bandTexels}) {
        for (int k = 0; k < 8; ++k) {
            const double angle = k * 0.25 * 3.14159265358979323846;
            const glm::dvec3 shift = std::cos(angle) * s1 + std::sin(angle) * s2;
            const glm::dvec3 aim = glm::normalize(p + radius * texel * shift - lightPos);
            const double hit = caster_.closestHit(lightPos, aim);
            // Where the shifted ray meets p's tangent plane (the surface p lies on).
            const double denom = glm::dot(aim, n);
            const double onPlane = std::abs(denom) > 1e-12 ? glm::dot(p - lightPos, n) / denom : 1e300;
            const bool samePlane = std::abs(hit - onPlane) <= tolerance;
            const bool sameAnswerAsP = firstHit >= dist - tolerance ? samePlane : hit < onPlane - tolerance;
            if (!sameAnswerAsP) return RayClass::NearEdge;
        }
    }
    return firstHit < dist - tolerance ? RayClass::Shadowed : RayClass::Lit;
}

RayCastAgreement compareWithRayCast(const LightRayClassifier& classifier, const FrameImages& frame,
                                    const AgreementOptions& options)
{
    RayCastAgreement result;
    for (uint32_t y = 0; y < frame.height; y += options.stride) {
        for (uint32_t x = 0; x < frame.width; x += options.stride) {
            const size_t i = size_t(y) * frame.width + x;
            const float* pos = &frame.positions[4 * i];
            const float* nrm = &frame.normals[4 * i];
            if (pos[3] == 0.0f) continue;
            const glm::dvec3 p(pos[0], pos[1], pos[2]);
            const RayClass c = classifier.classify(p, glm::dvec3(nrm[0], nrm[1], nrm[2]), options.bandTexels);
            if (c != RayClass::Lit && c != RayClass::Shadowed) continue;
            const bool shadowed = c == RayClass::Shadowed;
            (shadowed ? result.surelyShadowed : result.surelyLit)++;
            const float expected = shadowed ? 0.0f : 1.0f;
            if (!(std::abs(frame.visibility[i] - expected) <= options.tolerance) && ++result.mismatches <= 10) {
                ADD_FAILURE() << options.label << (options.label.empty() ? "" : ", ") << "pixel (" << x << ", " << y
                              << ") at (" << p.x << ", " << p.y << ", " << p.z << "): rays from the light say "
                              << (shadowed ? "shadowed" : "lit") << " but V = " << frame.visibility[i];
            }
        }
    }
    return result;
}

} // namespace penumbra::test
