#include "PluginFrame.h"

#include "penumbra/render/Projection.h"

#include <gtest/gtest.h>

namespace penumbra::test {

RenderedFrame::RenderedFrame(gpu::Context& context, plugin::PluginRegistry& reg, const config::RenderConfig& cfg,
                             scene::Scene s)
    : registry(reg), config(cfg), scene(std::move(s)), renderer(context, scene, config, reg)
{
    renderer.renderFrame();
    positions = renderer.readPositions();
    normals = renderer.readNormals();
}

std::vector<float> RenderedFrame::checkedVisibility(size_t l) const
{
    std::vector<float> v = renderer.readVisibility(l);
    EXPECT_EQ(v.size(), size_t(config.width) * config.height);
    for (size_t i = 0; i < v.size(); ++i) {
        if (!(std::isfinite(v[i]) && v[i] >= 0.0f && v[i] <= 1.0f) || (!hasGeometry(i) && v[i] != 1.0f)) {
            ADD_FAILURE() << "light " << l << ", pixel (" << i % config.width << ", " << i / config.width
                          << "): V = " << v[i] << (hasGeometry(i) ? "" : " where there is no geometry");
            break;
        }
    }
    return v;
}

LightRayClassifier RenderedFrame::classifier(size_t l) const
{
    const config::LightConfig& lc = config.lights[l];
    const nlohmann::json* resolution = lc.shadow.param("resolution");
    const uint32_t texels = resolution ? resolution->get<uint32_t>()
                                       : uint32_t(registry.load(lc.shadow.technique).defaultParams().getInt("resolution"));
    return LightRayClassifier(scene, lc.light, render::shadowFrusta(lc.light, scene.bounds()), texels);
}

void PluginGpuTest::SetUp()
{
    GpuTest::SetUp();
    registry = std::make_unique<plugin::PluginRegistry>();
}

void PluginGpuTest::TearDown()
{
    frame.reset();
    registry.reset();
    GpuTest::TearDown();
}

void PluginGpuTest::render(const config::RenderConfig& cfg, scene::Scene scene)
{
    frame.reset();
    frame = std::make_unique<RenderedFrame>(*context, *registry, cfg, std::move(scene));
}

RayCastAgreement RenderedFrame::rayCastAgreement(const std::vector<float>& v, double bandTexels, float tolerance,
                                                const std::string& label) const
{
    const FrameImages images{positions, normals, v, config.width, config.height};
    return compareWithRayCast(classifier(0), images, {2, bandTexels, tolerance, label});
}

} // namespace penumbra::test
