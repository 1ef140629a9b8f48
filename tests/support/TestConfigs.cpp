#include "TestConfigs.h"

#include "TestPaths.h"  // support/: the build tree's paths

#include "penumbra/scene/Generators.h"

#include <fmt/format.h>
#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace penumbra::test {

std::ostream& operator<<(std::ostream& os, const LightCase& c) { return os << c.name; }

void expectNear(const glm::vec3& actual, const glm::vec3& expected, float eps)
{
    EXPECT_NEAR(actual.x, expected.x, eps) << "y " << actual.y << " z " << actual.z;
    EXPECT_NEAR(actual.y, expected.y, eps) << "x " << actual.x << " z " << actual.z;
    EXPECT_NEAR(actual.z, expected.z, eps) << "x " << actual.x << " y " << actual.y;
}

std::filesystem::path gltfFile(const std::string& name)
{
    return penumbra::test::testDataDir() / "gltf" / name;
}

std::vector<config::SweepVariant> everyVariant(const config::ConfigDocument& document)
{
    const config::SweepVariants variants(document);
    std::vector<config::SweepVariant> out;
    for (size_t i = 0; i < variants.size(); ++i) out.push_back(variants.variant(i));
    return out;
}

config::RenderConfig defaultTestConfig()
{
    config::RenderConfig c = config::loadConfig(penumbra::test::sourceDir() / "config/default.json");
    c.width = 320;
    c.height = 180;
    return c;
}

void scaleConfig(config::RenderConfig& c, float s)
{
    // Scaled about the origin: each part's placement too.
    for (config::ScenePart& part : c.scene.parts) {
        part.transform.translation *= double(s);
        part.transform.scale *= double(s);
    }
    c.camera.position *= s;
    c.camera.target *= s;
    c.camera.nearWorld *= s;
    for (config::LightConfig& l : c.lights) {
        l.light.position *= s;
        // An area light's extent too: left unscaled, a disk of radius 0.5 over a scene a
        // thousandth the size straddled every receiver's horizon (V = 0.51 on box sides).
        l.light.sizeWorld *= s;
        l.light.radiusWorld *= s;
        // Directional: an irradiance already, the same at every distance.
        if (l.light.type != scene::LightType::Directional) l.light.intensity *= s * s;
    }
}

void setLightType(config::LightConfig& lightConfig, scene::LightType type)
{
    scene::Light& light = lightConfig.light;
    light.type = type;
    switch (type) {
    case scene::LightType::Spot:
        break;
    case scene::LightType::Directional:
        light.direction = glm::normalize(glm::vec3(0.6f, -1.0f, -0.35f));
        light.intensity = 3.0f;
        break;
    case scene::LightType::Point:
        light.position = {-2.0f, 7.0f, 3.0f};
        light.intensity = 150.0f;
        break;
    case scene::LightType::Rect:
    case scene::LightType::Disk:
        light.position = {-3.0f, 9.0f, 4.0f};
        light.direction = {0.0f, -1.0f, 0.0f};
        light.sizeWorld = {1.0f, 0.5f};
        light.radiusWorld = 0.5f;
        light.intensity = 300.0f;
        break;
    }
}

scene::Scene planeScene()
{
    scene::Scene s;
    scene::Mesh plane = scene::makePlane("plane");
    plane.computeBounds();
    s.meshes = {plane};
    s.addInstance(0, s.graph.addNode("plane", scene::kNoParent, glm::scale(glm::mat4(1.0f), glm::vec3(20, 1, 20))));
    return s;
}

uint32_t addMesh(scene::Scene& s, scene::Mesh mesh)
{
    mesh.computeBounds();
    s.meshes.push_back(std::move(mesh));
    return uint32_t(s.meshes.size() - 1);
}

uint32_t addInstance(scene::Scene& s, uint32_t mesh, const std::string& name, const glm::mat4& transform)
{
    return s.addInstance(mesh, s.graph.addNode(name, scene::kNoParent, transform));
}

scene::Scene boxOnGroundScene()
{
    scene::Scene s = planeScene();
    scene::Mesh box = scene::makeBox("box");
    box.computeBounds();
    s.meshes.push_back(box);
    s.addInstance(1, s.graph.addNode("box", scene::kNoParent, glm::translate(glm::mat4(1.0f), {0.0f, 0.5f, 0.0f})));
    return s;
}

config::RenderConfig lookDownRectLightConfig(glm::vec3 cameraPosition, glm::vec3 lightPosition, float lightSide)
{
    config::RenderConfig cfg = defaultTestConfig();
    cfg.camera.position = cameraPosition;
    cfg.camera.target = {cameraPosition.x, 0.0f, cameraPosition.z};
    cfg.camera.up = {0.0f, 0.0f, -1.0f};
    cfg.camera.fovYDeg = 60.0f;
    cfg.camera.nearWorld = 0.01f;
    cfg.lights.resize(1);
    scene::Light& light = cfg.lights[0].light;
    light = {};
    light.type = scene::LightType::Rect;
    light.position = lightPosition;
    light.direction = {0.0f, -1.0f, 0.0f};
    light.sizeWorld = {lightSide, lightSide};
    light.intensity = 40.0f;
    return cfg;
}

config::RenderConfig boxOnGroundConfig()
{
    config::RenderConfig cfg = lookDownRectLightConfig({1.3f, 2.5f, 0.0f}, {-3.0f, 3.0f, 0.0f}, 0.5f);
    cfg.lights[0].shadow = {};
    return cfg;
}

scene::Scene platformScene()
{
    scene::Scene s = planeScene();
    addInstance(s, addMesh(s, scene::makeBox("pillar")), "pillar",
                glm::scale(glm::translate(glm::mat4(1.0f), {0.0f, 0.5f, 0.0f}), {0.3f, 1.0f, 0.3f}));
    addInstance(s, addMesh(s, scene::makePlane("plate")), "plate",
                glm::scale(glm::translate(glm::mat4(1.0f), {0.0f, 1.2f, 0.0f}), {0.3f, 1.0f, 0.3f}));
    return s;
}

config::RenderConfig platformConfig()
{
    return lookDownRectLightConfig({0.0f, 1.15f, 0.0f}, {0.0f, 4.0f, 0.0f}, 1.0f);
}

config::RenderConfig planeUnderDirectionalLightConfig(float degreesFromNormal)
{
    config::RenderConfig cfg = defaultTestConfig();
    cfg.camera.position = {0.0f, 12.0f, 0.5f};
    cfg.camera.target = {0.0f, 0.0f, 0.0f};
    cfg.lights.resize(1);
    const float a = glm::radians(degreesFromNormal);
    cfg.lights[0].light = {};
    cfg.lights[0].light.type = scene::LightType::Directional;
    cfg.lights[0].light.direction = {std::sin(a), -std::cos(a), 0.0f};
    return cfg;
}

scene::Scene panesScene(const std::vector<float>& heights, float alpha, const std::vector<float>& opaque, float scale)
{
    scene::Scene s = planeScene();
    s.materials.push_back({"glass", {1.0f, 1.0f, 1.0f, alpha}, scene::kNoTexture, scene::AlphaMode::Blend, 0.5f, true});
    scene::Mesh pane = scene::makePlane("pane");
    pane.material = uint32_t(s.materials.size() - 1);
    const uint32_t translucent = addMesh(s, pane);
    const auto place = [scale](float h) {
        return glm::scale(glm::mat4(1.0f), glm::vec3(scale)) *
               glm::scale(glm::translate(glm::mat4(1.0f), glm::vec3(0, h, 0)), glm::vec3(2, 1, 2));
    };
    s.graph.setLocal(s.instances[0].node, glm::scale(s.graph.local(s.instances[0].node), glm::vec3(scale)));
    for (float h : heights) addInstance(s, translucent, fmt::format("pane{}", h), place(h));
    if (!opaque.empty()) {
        pane.material = 0;
        const uint32_t plate = addMesh(s, pane);
        for (float h : opaque) addInstance(s, plate, fmt::format("plate{}", h), place(h));
    }
    s.updateTransforms();
    return s;
}

glm::mat4 wallAt(float x)
{
    // Rotating -90 degrees about z takes the square's normal +y to +x.
    return glm::translate(glm::mat4(1.0f), {x, 1.0f, 0.0f}) *
           glm::rotate(glm::mat4(1.0f), -0.5f * std::numbers::pi_v<float>, {0.0f, 0.0f, 1.0f}) *
           glm::scale(glm::mat4(1.0f), {2.0f, 1.0f, 2.0f});
}

uint32_t addHalfMaskedMaterial(scene::Scene& s)
{
    scene::Texture texture{"half", 4, 1, std::vector<uint8_t>(4 * 4, 200)};
    for (int x = 0; x < 4; ++x) texture.rgba[4 * x + 3] = x < 2 ? 0 : 255;  // alpha
    s.textures.push_back(texture);
    s.materials.push_back({"masked", {1, 1, 1, 1}, int32_t(s.textures.size() - 1), scene::AlphaMode::Mask, 0.5f, true});
    return uint32_t(s.materials.size() - 1);
}

scene::Scene halfMaskedQuadScene()
{
    scene::Scene s;
    const uint32_t masked = addHalfMaskedMaterial(s);
    scene::Mesh ground = scene::makePlane("ground");
    scene::Mesh quad = scene::makePlane("quad");
    quad.material = masked;
    for (scene::Mesh* m : {&ground, &quad}) m->computeBounds();
    s.meshes = {ground, quad};
    const glm::mat4 identity(1.0f);
    s.addInstance(0, s.graph.addNode("ground", scene::kNoParent, glm::scale(identity, glm::vec3(20, 1, 20))));
    s.addInstance(1, s.graph.addNode("quad", scene::kNoParent,
                                     glm::scale(glm::translate(identity, glm::vec3(0, 2, 0)), glm::vec3(4, 1, 4))));
    return s;
}

config::RenderConfig halfMaskedQuadConfig()
{
    config::RenderConfig cfg = defaultTestConfig();
    cfg.camera.position = {0.0f, 12.0f, 0.5f};
    cfg.camera.target = {0.0f, 0.0f, 0.0f};
    cfg.lights.resize(1);
    cfg.lights[0].light.type = scene::LightType::Directional;
    cfg.lights[0].light.direction = glm::normalize(glm::vec3(1.0f, -2.0f, 0.0f));
    cfg.lights[0].light.intensity = 2.0f;
    cfg.lights[0].shadow.setParam("resolution", 1024, "test");
    return cfg;
}

} // namespace penumbra::test
