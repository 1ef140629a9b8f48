// Images nobody reads are not written (plugin/VisibilityFunction.h): where nothing but
// shading reads V_l (FrameRenderer::setVisibilityReadBack(false)), shading evaluates the
// technique's visibility function itself, the light has neither a visibility pass nor an
// image, and the frame equals, bit for bit, the frame that writes and reads the image:
// for every technique that gives its visibility as a function, its variants, every light
// type, several lights that share one technique's code under different defines, and
// over animated frames.
#include "PluginFrame.h"
#include "TestConfigs.h"
#include "TestContext.h"

#include "penumbra/config/Config.h"
#include "penumbra/core/Error.h"
#include "penumbra/frame/FrameRenderer.h"
#include "penumbra/gpu/GlslNames.h"

#include <glm/gtc/matrix_transform.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

using namespace penumbra;

namespace {

struct InShadingCase {
    const char* technique;
    nlohmann::json params;
    test::LightCase light;
};

std::ostream& operator<<(std::ostream& os, const InShadingCase& c) { return os << c.technique << " " << c.params.dump() << "/" << c.light; }

bool hasPassNamed(const frame::FrameTimings& timings, const std::string& name)
{
    return std::any_of(timings.passes.begin(), timings.passes.end(),
                       [&](const graph::PassTiming& p) { return p.name == name; });
}

class VisibilityInShading : public test::GpuTest, public ::testing::WithParamInterface<InShadingCase> {};
class VisibilityInShadingFrames : public test::GpuTest {};

} // namespace

TEST_P(VisibilityInShading, SamePixelsWithoutTheImage)
{
    const InShadingCase& c = GetParam();
    config::RenderConfig config = test::defaultTestConfig();
    config.width = 96;
    config.height = 54;
    test::setLightType(config.lights[0], c.light.type);
    nlohmann::json params = c.params;
    params["resolution"] = 256;
    test::setShadow(config.lights[0], c.technique, params);
    config.lights[0].shadow.required = true;
    scene::Scene scene = config::buildScene(config);

    frame::FrameRenderer withImage(*context, scene, config, test::plugins());
    frame::FrameRenderer inShading(*context, scene, config, test::plugins());
    inShading.setVisibilityReadBack(false);
    ASSERT_TRUE(inShading.visibilityInShading(0));
    ASSERT_FALSE(withImage.visibilityInShading(0));
    const std::vector<std::string> images = inShading.imageNames();
    EXPECT_EQ(std::count(images.begin(), images.end(), "light0.visibility"), 0) << "the image is still declared";

    const frame::FrameTimings a = withImage.renderFrame();
    const frame::FrameTimings b = inShading.renderFrame();
    const std::string pass = "light0." + std::string(c.technique) + ".visibility";
    EXPECT_TRUE(hasPassNamed(a, pass));
    EXPECT_FALSE(hasPassNamed(b, pass)) << "the visibility pass still runs";
    const std::vector<uint8_t> expected = withImage.readColor();
    EXPECT_EQ(inShading.readColor(), expected) << "shading's own evaluation differs from the image's";
    // The frame shows the shadow: some of the light's pixels are dark.
    const std::vector<float> v = withImage.readVisibility(0);
    EXPECT_LT(*std::min_element(v.begin(), v.end()), 0.5f);

    // Back to an image: read back as before.
    inShading.setVisibilityReadBack(true);
    EXPECT_FALSE(inShading.visibilityInShading(0));
    inShading.renderFrame();
    EXPECT_EQ(inShading.readVisibility(0), v);
}

INSTANTIATE_TEST_SUITE_P(
    EveryFunctionTechnique, VisibilityInShading,
    ::testing::ValuesIn([] {
        std::vector<InShadingCase> cases;
        const test::LightCase lights[] = {{"spot", scene::LightType::Spot},
                                          {"point", scene::LightType::Point},
                                          {"rect", scene::LightType::Rect},
                                          {"disk", scene::LightType::Disk},
                                          {"directional", scene::LightType::Directional}};
        for (const test::LightCase& light : lights) {
            cases.push_back({"hard", {{"filter", "pcf"}, {"pcf_kernel", 5}}, light});
            cases.push_back({"pcss", nlohmann::json::object(), light});
            cases.push_back({"vsm", nlohmann::json::object(), light});
        }
        const test::LightCase spot = lights[0];
        cases.push_back({"hard", {{"filter", "none"}, {"bias_mode", "slope"}}, spot});
        cases.push_back({"hard", {{"filter", "poisson"}, {"bias_mode", "normal_offset"}, {"normal_offset", 1.3}}, spot});
        cases.push_back({"hard", {{"filter", "bilinear"}, {"bias_mode", "receiver_plane"}}, lights[4]});
        cases.push_back({"hard", {{"filter", "bilinear"}, {"bias_mode", "constant"}}, lights[1]});
        cases.push_back({"pcss", {{"bias_mode", "slope"}}, spot});
        cases.push_back({"vsm", {{"variant", "evsm"}, {"filter", "box"}}, spot});
        cases.push_back({"vsm", {{"variant", "esm"}, {"filter", "trilinear"}}, lights[4]});
        cases.push_back({"vsm", {{"variant", "vsm"}, {"filter", "anisotropic"}}, lights[1]});
        return cases;
    }()),
    [](const auto& info) {
        std::string name = std::string(info.param.technique) + "_" + std::to_string(info.index) + "_" +
                           info.param.light.name;
        return name;
    });

// Three lights, two of them hard with different variants (one library, two sets of
// defines and bindings in one shader), one pcss, and one technique without a function
// (vssm keeps its image), over frames where a caster and the camera move.
TEST_F(VisibilityInShadingFrames, SeveralLightsSharingOneTechniqueOverAnimatedFrames)
{
    config::RenderConfig config = test::defaultTestConfig();
    config.width = 96;
    config.height = 54;
    test::setShadow(config.lights[0], "hard", {{"resolution", 256}, {"filter", "pcf"}, {"pcf_kernel", 3}});
    const config::LightConfig base = config.lights[0];
    const auto addLight = [&](const char* name, glm::vec3 position, scene::LightType type, const char* technique,
                              nlohmann::json params) {
        config::LightConfig l = base;
        l.name = name;
        l.light.position = position;
        l.light.direction = glm::normalize(-position);
        test::setLightType(l, type);
        params["resolution"] = 256;
        test::setShadow(l, technique, params);
        config.lights.push_back(l);
    };
    addLight("second", {6.0f, 14.0f, -8.0f}, scene::LightType::Point, "hard",
             {{"filter", "poisson"}, {"bias_mode", "normal_offset"}});
    addLight("third", {-7.0f, 12.0f, 5.0f}, scene::LightType::Spot, "pcss", nlohmann::json::object());
    addLight("fourth", {3.0f, 10.0f, 9.0f}, scene::LightType::Spot, "vssm", nlohmann::json::object());
    for (config::LightConfig& l : config.lights) l.shadow.required = true;
    scene::Scene scene = config::buildScene(config);

    frame::FrameRenderer withImage(*context, scene, config, test::plugins());
    frame::FrameRenderer inShading(*context, scene, config, test::plugins());
    inShading.setVisibilityReadBack(false);
    for (size_t l = 0; l < 3; ++l) EXPECT_TRUE(inShading.visibilityInShading(l)) << "light " << l;
    EXPECT_FALSE(inShading.visibilityInShading(3)) << "vssm gives no function";

    uint32_t box = 0;
    for (uint32_t n = 0; n < scene.graph.size(); ++n)
        if (scene.graph.node(n).name == "box_2_2") box = n;
    const glm::mat4 rest = scene.graph.local(box);
    for (int frame = 0; frame < 3; ++frame) {
        SCOPED_TRACE(frame);
        scene.graph.setLocal(box, glm::translate(glm::mat4(1.0f), glm::vec3(0.5f * float(frame), 0.0f, 0.3f)) * rest);
        config.camera.position += glm::vec3(0.3f, 0.1f, -0.2f);
        const std::vector<uint32_t> moved = scene.updateTransforms();
        withImage.update(config, scene, moved);
        inShading.update(config, scene, moved);
        withImage.renderFrame();
        inShading.renderFrame();
        ASSERT_EQ(inShading.readColor(), withImage.readColor());
    }
    EXPECT_EQ(inShading.readVisibility(3), withImage.readVisibility(3)) << "vssm's image";
    try {
        inShading.readVisibility(1);
        ADD_FAILURE() << "read a visibility that has no image";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("light 1: shading evaluates its visibility"), std::string::npos) << e.what();
    }
    EXPECT_THROW(inShading.readPixel(3, 4), Error);
}

// The renaming on its own: file-scope names get the prefix, members and built-ins do not.
TEST(GlslNames, PrefixesWhatTheUnitDeclaresAndNothingElse)
{
    const std::string unit = "#line 1 \"x.glsl\"\n"
                             "#extension GL_EXT_samplerless_texture_functions : require\n"
                             "struct Receiver { uint face; vec2 uv; };\n"
                             "layout(binding = 9) uniform sampler2D depthMap;\n"
                             "layout(std430, binding = 10) readonly buffer MapBuffer { Receiver r; float face[2]; } mapBuffer;\n"
                             "const float kTaps[2] = float[2](1.0, 2e-3), kOther = 1.5e+2;\n"
                             "float depthAt(vec2 uv) { return texture(depthMap, uv).r; }\n"
                             "float face(Receiver r) { return float(r.face) + mapBuffer.face[1]; }\n"
                             "float techniqueVisibility(ivec2 pixel, vec3 position, vec3 normal)\n"
                             "{ Receiver r = Receiver(0u, vec2(0.5)); float x = depthAt(r.uv) * kTaps[1] + kOther;"
                             " return face(r) + x + gbufferSize().x; }\n";
    const gpu::PrefixedUnit p = gpu::prefixTopLevelNames(unit, "l3_");
    EXPECT_EQ(p.names, (std::vector<std::string>{"MapBuffer", "Receiver", "depthAt", "depthMap", "face", "kOther",
                                                 "kTaps", "mapBuffer", "techniqueVisibility"}));
    EXPECT_EQ(p.extensions, (std::vector<std::string>{"#extension GL_EXT_samplerless_texture_functions : require"}));
    for (const char* expected :
         {"struct l3_Receiver { uint face; vec2 uv; }", "uniform sampler2D l3_depthMap;", "buffer l3_MapBuffer { l3_Receiver r; float face[2]; } l3_mapBuffer;",
          "const float l3_kTaps[2] = float[2](1.0, 2e-3), l3_kOther = 1.5e+2;", "float l3_depthAt(vec2 uv) { return texture(l3_depthMap, uv).r; }",
          "float l3_face(l3_Receiver r) { return float(r.face) + l3_mapBuffer.face[1]; }",
          "float l3_techniqueVisibility(ivec2 pixel", "l3_Receiver r = l3_Receiver(0u, vec2(0.5));",
          "l3_depthAt(r.uv) * l3_kTaps[1] + l3_kOther;", "return l3_face(r) + x + gbufferSize().x;"}) {
        EXPECT_NE(p.text.find(expected), std::string::npos) << expected << "\nin\n" << p.text;
    }
    EXPECT_EQ(p.text.find('#'), std::string::npos) << p.text;
    EXPECT_THROW(gpu::prefixTopLevelNames("float f() { return 1.0;", "x_"), Error);
    EXPECT_THROW(gpu::prefixTopLevelNames("float f() { return 1.0; } }", "x_"), Error);
}
