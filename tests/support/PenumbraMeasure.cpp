#include "PenumbraMeasure.h"

#include "TestConfigs.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>

namespace penumbra::test {

scene::PenumbraParams penumbraParams(const PenumbraSetup& p)
{
    scene::PenumbraParams params;
    params.occluderHeight = p.occluderHeight;
    params.occluderThickness = p.occluderThickness;
    return params;
}

config::RenderConfig penumbraConfig(const PenumbraSetup& p)
{
    config::RenderConfig cfg = lookDownRectLightConfig({1.0f, 0.8f, 0.0f}, {0.0f, kPenumbraLightHeight, 0.0f}, p.lightSide);
    cfg.scene = {};
    return cfg;
}

double rampWidth(const std::vector<std::pair<float, float>>& samples)
{
    std::map<int, std::pair<double, int>> bins;  // bin -> (sum of V, count)
    for (const auto& [coordinate, v] : samples) {
        auto& bin = bins[int(std::floor(coordinate / 0.01f))];
        bin.first += v;
        ++bin.second;
    }
    double at10 = NAN, at90 = NAN;
    for (const auto& [bin, sum] : bins) {
        const double mean = sum.first / sum.second, coordinate = (bin + 0.5) * 0.01;
        if (std::isnan(at10) && mean >= 0.1) at10 = coordinate;
        if (std::isnan(at90) && mean >= 0.9) at90 = coordinate;
    }
    return at90 - at10;
}

double edgeWidth(const RenderedFrame& frame, const std::vector<float>& v)
{
    std::vector<std::pair<float, float>> samples;
    for (size_t i = 0; i < v.size(); ++i) {
        if (frame.onGround(i) && std::abs(frame.position(i).z) <= 0.05f) samples.emplace_back(frame.position(i).x, v[i]);
    }
    return rampWidth(samples);
}

double sideEdgeWidth(const RenderedFrame& frame, const std::vector<float>& v, float x)
{
    std::vector<std::pair<float, float>> samples;
    for (size_t i = 0; i < v.size(); ++i) {
        const glm::vec3 p = frame.position(i);
        if (frame.onGround(i) && std::abs(p.x - x) <= 0.02f && p.z >= 0.0f) samples.emplace_back(p.z, v[i]);
    }
    return rampWidth(samples);
}

FootShadow footShadow(const RenderedFrame& frame, const std::vector<float>& v, double texelWorld, float umbraMax)
{
    FootShadow foot;
    for (size_t i = 0; i < v.size(); ++i) {
        const glm::vec3 q = frame.position(i);
        if (!frame.onGround(i) || std::abs(q.z) > 0.3f || q.x < 0.5f + 4.0f * texelWorld || q.x > 0.65f) continue;
        ++foot.pixels;
        foot.notUmbra += v[i] > umbraMax;
    }
    return foot;
}

PenumbraWidths measurePenumbra(const RenderedFrame& frame, const std::vector<float>& v, const PenumbraSetup& p)
{
    const scene::PenumbraParams params = penumbraParams(p);
    std::vector<float> exact(v.size(), 1.0f);
    double squared = 0.0, penumbraSquared = 0.0;
    size_t ground = 0, penumbra = 0;
    const scene::RectAreaLight light{{0.0f, kPenumbraLightHeight, 0.0f}, {p.lightSide, p.lightSide}};
    for (size_t i = 0; i < v.size(); ++i) {
        if (!frame.onGround(i)) continue;
        const glm::vec3 q = frame.position(i);
        exact[i] = float(scene::penumbraVisibility(params, light, {q.x, q.z}));
        const double e = (v[i] - exact[i]) * (v[i] - exact[i]);
        squared += e;
        ++ground;
        if (exact[i] > 0.001f && exact[i] < 0.999f) {
            penumbraSquared += e;
            ++penumbra;
        }
    }
    EXPECT_GT(ground, v.size() / 2) << "the camera sees the ground";
    return {edgeWidth(frame, v), edgeWidth(frame, exact), std::sqrt(squared / double(std::max<size_t>(ground, 1))),
            std::sqrt(penumbraSquared / double(std::max<size_t>(penumbra, 1)))};
}

} // namespace penumbra::test
