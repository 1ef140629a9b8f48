#include "PluginFrame.h"

#include "penumbra/core/Error.h"
#include "penumbra/render/Projection.h"

#include <gtest/gtest.h>

namespace penumbra::test {

RenderedFrame::RenderedFrame(gpu::Context& context, plugin::PluginRegistry& reg, const config::RenderConfig& cfg,
                             scene::Scene s, const std::vector<std::string>& debugImages)
    : registry(reg), config(cfg), scene(std::move(s)), renderer(context, scene, config, reg)
{
    for (const std::string& image : debugImages) renderer.requestImage(image);
    timings = renderer.renderFrame();
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

void PluginGpuTest::render(const config::RenderConfig& cfg, scene::Scene scene, const std::vector<std::string>& debugImages)
{
    frame.reset();
    frame = std::make_unique<RenderedFrame>(*context, *registry, cfg, std::move(scene), debugImages);
}

void PluginGpuTest::expectRayCastAgreement(const std::vector<float>& v, double bandTexels, float tolerance,
                                           const std::string& label) const
{
    const RayCastAgreement a = frame->rayCastAgreement(v, bandTexels, tolerance, label);
    EXPECT_EQ(a.mismatches, 0u) << label;
    EXPECT_GT(a.surelyShadowed, 150u) << label;
    EXPECT_GT(a.surelyLit, 2000u) << label;
}

void PluginGpuTest::expectExactlyLitWhereGeometry(const std::vector<float>& v, const std::string& label) const
{
    size_t seen = 0, notLit = 0;
    for (size_t i = 0; i < v.size(); ++i) {
        if (!frame->hasGeometry(i)) continue;
        ++seen;
        notLit += v[i] != 1.0f;
    }
    EXPECT_GT(seen, v.size() / 2) << label << ": pixels that see geometry";
    EXPECT_EQ(notLit, 0u) << label;
}

void setShadow(config::LightConfig& light, const std::string& technique, const nlohmann::json& params)
{
    config::ShadowSettings& shadow = light.shadow;
    shadow = {};
    shadow.technique = technique;
    shadow.required = true;
    for (const auto& [name, value] : params.items()) shadow.setParam(name, value, "test");
}

void expectRefusalsNameTheParameter(const std::string& plugin,
                                    const std::vector<std::pair<std::string, nlohmann::json>>& values)
{
    plugin::PluginRegistry registry;
    plugin::ParamValues params = registry.load(plugin).defaultParams();
    for (const auto& [name, value] : values) {
        try {
            params.set(name, value, "test.json: /lights/0/shadow");
            ADD_FAILURE() << plugin << ": " << name << " = " << value << " was accepted";
        } catch (const ConfigError& e) {
            EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
        }
    }
}

RayCastAgreement RenderedFrame::rayCastAgreement(const std::vector<float>& v, double bandTexels, float tolerance,
                                                const std::string& label) const
{
    const FrameImages images{positions, normals, v, config.width, config.height};
    return compareWithRayCast(classifier(0), images, {2, bandTexels, tolerance, label});
}

} // namespace penumbra::test
