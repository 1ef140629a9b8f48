// The peer program of docs/performance.md, "Against osgShadow": the box field that
// `penumbra generate box-field` writes, drawn by OpenSceneGraph 3.6 with
// osgShadow::ShadowMap (one depth map from a directional light, one compare per pixel in
// a forward pass) into an off-screen pbuffer, so that Penumbra's hard frame can be set
// against a well-known engine's shadow-map frame on the same rasterizer (Mesa's
// llvmpipe behind both OpenGL and Vulkan). Prints the median frame time.
//
//   osgshadow_peer SCENE.gltf [--width W] [--height H] [--map TEXELS] [--frames N] [--warmup K]
//                  [--eye X Y Z] [--target X Y Z] [--fov DEG] [--light-dir X Y Z] [--png OUT.png]
//                  [--per-pixel]
//
// osgShadow::ShadowMap's own shaders light per vertex (the fixed-function pipeline's
// Gouraud colour) and do one compare per pixel. --per-pixel gives it shaders that do per
// pixel what Penumbra's shading does (engine/shading.glsl: Lambert from the light's
// direction and the interpolated normal, the sky ambient, the ACES tone map and the sRGB
// encoding), so that the two frames can also be set side by side for the same pixel work.
//
// The defaults are config/box-field.json's camera, light, output size and map size. A
// frame is timed from viewer.frame() until glFinish() has returned after its draw (the
// map pass and the forward pass), the way `penumbra render --timings` reports a frame's
// wall clock.
#include <osg/Camera>
#include <osg/Geode>
#include <osg/Geometry>
#include <osg/GL>
#include <osg/LightSource>
#include <osg/Material>
#include <osg/MatrixTransform>
#include <osg/Shader>
#include <osgDB/WriteFile>
#include <osgShadow/ShadowMap>
#include <osgShadow/ShadowedScene>
#include <osgViewer/Viewer>

#include <tiny_gltf.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

constexpr unsigned kReceives = 0x1, kCasts = 0x2;

struct Options {
    std::string scene;
    int width = 1280, height = 720, map = 2048, frames = 9, warmup = 2;
    osg::Vec3d eye{0.0, 46.0, 70.0}, target{0.0, 0.0, 4.0};
    double fovDeg = 50.0;
    osg::Vec3 lightDir{-0.55f, -0.7f, -0.45f};  // the direction the light travels
    std::string png;
    bool perPixel = false;
};

[[noreturn]] void usage(const std::string& why)
{
    std::fprintf(stderr, "osgshadow_peer: %s\nusage: osgshadow_peer SCENE.gltf [--width W] [--height H] [--map TEXELS] "
                         "[--frames N] [--warmup K] [--eye X Y Z] [--target X Y Z] [--fov DEG] [--light-dir X Y Z] "
                         "[--png OUT.png] [--per-pixel]\n",
                 why.c_str());
    std::exit(2);
}

double number(const char* text, const char* option)
{
    char* end = nullptr;
    const double v = std::strtod(text, &end);
    if (end == text || *end != '\0') usage(std::string(option) + ": '" + text + "' is not a number");
    return v;
}

Options parse(int argc, char** argv)
{
    Options o;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        const auto need = [&](int n) {
            if (i + n >= argc) usage(a + " needs " + std::to_string(n) + " value(s)");
        };
        const auto vec3 = [&]() {
            need(3);
            osg::Vec3d v(number(argv[i + 1], a.c_str()), number(argv[i + 2], a.c_str()), number(argv[i + 3], a.c_str()));
            i += 3;
            return v;
        };
        if (a == "--width") { need(1); o.width = int(number(argv[++i], "--width")); }
        else if (a == "--height") { need(1); o.height = int(number(argv[++i], "--height")); }
        else if (a == "--map") { need(1); o.map = int(number(argv[++i], "--map")); }
        else if (a == "--frames") { need(1); o.frames = int(number(argv[++i], "--frames")); }
        else if (a == "--warmup") { need(1); o.warmup = int(number(argv[++i], "--warmup")); }
        else if (a == "--fov") { need(1); o.fovDeg = number(argv[++i], "--fov"); }
        else if (a == "--eye") o.eye = vec3();
        else if (a == "--target") o.target = vec3();
        else if (a == "--light-dir") o.lightDir = osg::Vec3(vec3());
        else if (a == "--png") { need(1); o.png = argv[++i]; }
        else if (a == "--per-pixel") o.perPixel = true;
        else if (!a.empty() && a[0] == '-') usage("unknown option " + a);
        else if (o.scene.empty()) o.scene = a;
        else usage("more than one scene: " + a);
    }
    if (o.scene.empty()) usage("no scene");
    if (o.width < 1 || o.height < 1 || o.map < 16 || o.frames < 1 || o.warmup < 0 || !(o.fovDeg > 0.0 && o.fovDeg < 180.0) ||
        o.lightDir.length2() == 0.0f) {
        usage("--width, --height >= 1, --map >= 16, --frames >= 1, --warmup >= 0, --fov in (0, 180), --light-dir not 0");
    }
    return o;
}

// One float accessor's elements as osg vectors (POSITION, NORMAL: VEC3 floats).
osg::ref_ptr<osg::Vec3Array> vec3s(const tinygltf::Model& model, int index)
{
    const tinygltf::Accessor& accessor = model.accessors.at(size_t(index));
    if (accessor.type != TINYGLTF_TYPE_VEC3 || accessor.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT)
        throw std::runtime_error("accessor " + std::to_string(index) + ": expected VEC3 floats");
    const tinygltf::BufferView& view = model.bufferViews.at(size_t(accessor.bufferView));
    const unsigned char* base = model.buffers.at(size_t(view.buffer)).data.data() + view.byteOffset + accessor.byteOffset;
    const size_t stride = view.byteStride ? view.byteStride : 3 * sizeof(float);
    osg::ref_ptr<osg::Vec3Array> out = new osg::Vec3Array(accessor.count);
    for (size_t i = 0; i < accessor.count; ++i) std::memcpy(&(*out)[i], base + i * stride, 3 * sizeof(float));
    return out;
}

osg::ref_ptr<osg::DrawElementsUInt> indices(const tinygltf::Model& model, int index)
{
    const tinygltf::Accessor& accessor = model.accessors.at(size_t(index));
    const tinygltf::BufferView& view = model.bufferViews.at(size_t(accessor.bufferView));
    const unsigned char* base = model.buffers.at(size_t(view.buffer)).data.data() + view.byteOffset + accessor.byteOffset;
    osg::ref_ptr<osg::DrawElementsUInt> out = new osg::DrawElementsUInt(GL_TRIANGLES);
    out->reserve(accessor.count);
    for (size_t i = 0; i < accessor.count; ++i) {
        switch (accessor.componentType) {
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: { uint32_t v; std::memcpy(&v, base + 4 * i, 4); out->push_back(v); break; }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: { uint16_t v; std::memcpy(&v, base + 2 * i, 2); out->push_back(v); break; }
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: out->push_back(base[i]); break;
        default: throw std::runtime_error("accessor " + std::to_string(index) + ": unsupported index type");
        }
    }
    return out;
}

osg::Matrixd localMatrix(const tinygltf::Node& node)
{
    if (node.matrix.size() == 16) return osg::Matrixd(node.matrix.data());  // column-major, as osg's row vectors
    osg::Matrixd m;
    if (node.scale.size() == 3) m.postMultScale(osg::Vec3d(node.scale[0], node.scale[1], node.scale[2]));
    if (node.rotation.size() == 4)
        m.postMultRotate(osg::Quat(node.rotation[0], node.rotation[1], node.rotation[2], node.rotation[3]));
    if (node.translation.size() == 3)
        m.postMultTranslate(osg::Vec3d(node.translation[0], node.translation[1], node.translation[2]));
    return m;
}

// Every mesh its own Geode under its node's transform, as the glTF has it (the box field:
// 1,001 meshes), with the material's base colour.
osg::ref_ptr<osg::Node> buildNode(const tinygltf::Model& model, int index)
{
    const tinygltf::Node& node = model.nodes.at(size_t(index));
    osg::ref_ptr<osg::MatrixTransform> transform = new osg::MatrixTransform(localMatrix(node));
    if (node.mesh >= 0) {
        osg::ref_ptr<osg::Geode> geode = new osg::Geode;
        for (const tinygltf::Primitive& p : model.meshes.at(size_t(node.mesh)).primitives) {
            if (p.mode != TINYGLTF_MODE_TRIANGLES || p.indices < 0 || !p.attributes.count("POSITION") ||
                !p.attributes.count("NORMAL")) {
                throw std::runtime_error("mesh " + std::to_string(node.mesh) + ": expected indexed triangles with normals");
            }
            osg::ref_ptr<osg::Geometry> geometry = new osg::Geometry;
            geometry->setUseVertexBufferObjects(true);
            geometry->setUseDisplayList(false);
            geometry->setVertexArray(vec3s(model, p.attributes.at("POSITION")));
            geometry->setNormalArray(vec3s(model, p.attributes.at("NORMAL")), osg::Array::BIND_PER_VERTEX);
            geometry->addPrimitiveSet(indices(model, p.indices));
            if (p.material >= 0) {
                const std::vector<double>& c = model.materials.at(size_t(p.material)).pbrMetallicRoughness.baseColorFactor;
                osg::ref_ptr<osg::Material> material = new osg::Material;
                material->setDiffuse(osg::Material::FRONT_AND_BACK, osg::Vec4(float(c[0]), float(c[1]), float(c[2]), 1.0f));
                geometry->getOrCreateStateSet()->setAttributeAndModes(material);
            }
            geode->addDrawable(geometry);
        }
        transform->addChild(geode);
    }
    for (int child : node.children) transform->addChild(buildNode(model, child));
    return transform;
}

osg::ref_ptr<osg::Group> loadScene(const std::string& path)
{
    tinygltf::TinyGLTF loader;
    tinygltf::Model model;
    std::string error, warning;
    const bool binary = path.size() > 4 && path.compare(path.size() - 4, 4, ".glb") == 0;
    const bool ok = binary ? loader.LoadBinaryFromFile(&model, &error, &warning, path)
                           : loader.LoadASCIIFromFile(&model, &error, &warning, path);
    if (!ok) throw std::runtime_error(path + ": " + error);
    osg::ref_ptr<osg::Group> root = new osg::Group;
    const int scene = model.defaultScene >= 0 ? model.defaultScene : 0;
    if (model.scenes.empty()) throw std::runtime_error(path + ": no scene");
    for (int node : model.scenes.at(size_t(scene)).nodes) root->addChild(buildNode(model, node));
    return root;
}

// --per-pixel: ShadowMap's texture coordinates are eye-linear texgen on unit 1, which a
// vertex shader computes itself from the planes ShadowMap sets (gl_EyePlane*[1]).
constexpr const char* kPerPixelVertex = R"(#version 120
varying vec3 normalEye;
void main()
{
    vec4 eye = gl_ModelViewMatrix * gl_Vertex;
    gl_Position = ftransform();
    normalEye = gl_NormalMatrix * gl_Normal;
    gl_TexCoord[1] = vec4(dot(eye, gl_EyePlaneS[1]), dot(eye, gl_EyePlaneT[1]), dot(eye, gl_EyePlaneR[1]),
                          dot(eye, gl_EyePlaneQ[1]));
}
)";

// Penumbra's shading of one directional light with intensity 2 and config/box-field.json's
// sky (engine/shading.glsl, common/lambert.glsl, common/color.glsl), per pixel.
constexpr const char* kPerPixelFragment = R"(#version 120
uniform sampler2DShadow osgShadow_shadowTexture;
uniform mat4 osg_ViewMatrixInverse;
varying vec3 normalEye;
void main()
{
    vec3 n = normalize(normalEye);
    vec3 albedo = gl_FrontMaterial.diffuse.rgb;
    float v = shadow2DProj(osgShadow_shadowTexture, gl_TexCoord[1]).r;
    float cosTheta = max(dot(n, normalize(gl_LightSource[0].position.xyz)), 0.0);
    vec3 radiance = albedo / 3.14159265 * 2.0 * (cosTheta * v);
    float up = (mat3(osg_ViewMatrixInverse) * n).y;
    radiance += albedo * vec3(0.15, 0.15, 0.17) * (0.6 + 0.4 * up);
    vec3 x = min(radiance, vec3(1e4));
    x = clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
    vec3 srgb = mix(12.92 * x, 1.055 * pow(x, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), x));
    gl_FragColor = vec4(srgb, 1.0);
}
)";

// Waits for the frame's GL work: the frame is timed up to here. Notes which OpenGL
// renderer drew it (the context is current only while the frame draws).
struct FinishCallback : osg::Camera::DrawCallback {
    void operator()(osg::RenderInfo&) const override
    {
        glFinish();
        if (renderer.empty()) {
            const GLubyte* name = glGetString(GL_RENDERER);
            renderer = name ? reinterpret_cast<const char*>(name) : "?";
        }
    }
    mutable std::string renderer;
};

double median(std::vector<double> v)
{
    std::sort(v.begin(), v.end());
    const size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

} // namespace

int main(int argc, char** argv)
{
    const Options o = parse(argc, argv);
    try {
        osg::ref_ptr<osg::Group> scene = loadScene(o.scene);
        scene->setNodeMask(kReceives | kCasts);

        osg::ref_ptr<osg::LightSource> source = new osg::LightSource;
        osg::Vec3 towards = -o.lightDir;
        towards.normalize();
        source->getLight()->setLightNum(0);
        source->getLight()->setPosition(osg::Vec4(towards, 0.0f));  // w = 0: directional
        source->getLight()->setDiffuse(osg::Vec4(1.0f, 1.0f, 1.0f, 1.0f));
        source->getLight()->setAmbient(osg::Vec4(0.15f, 0.15f, 0.17f, 1.0f));

        osg::ref_ptr<osgShadow::ShadowMap> technique = new osgShadow::ShadowMap;
        technique->setTextureSize(osg::Vec2s(short(o.map), short(o.map)));
        technique->setLight(source.get());
        if (o.perPixel) {
            technique->addShader(new osg::Shader(osg::Shader::VERTEX, kPerPixelVertex));
            technique->addShader(new osg::Shader(osg::Shader::FRAGMENT, kPerPixelFragment));
        }
        osg::ref_ptr<osgShadow::ShadowedScene> shadowed = new osgShadow::ShadowedScene(technique.get());
        shadowed->setReceivesShadowTraversalMask(kReceives);
        shadowed->setCastsShadowTraversalMask(kCasts);
        shadowed->addChild(source);
        shadowed->addChild(scene);

        osg::ref_ptr<osg::GraphicsContext::Traits> traits = new osg::GraphicsContext::Traits;
        traits->readDISPLAY();  // the X server's display, as xvfb-run sets it
        traits->setUndefinedScreenDetailsToDefaultScreen();
        traits->width = o.width;
        traits->height = o.height;
        traits->pbuffer = true;
        traits->doubleBuffer = false;
        traits->red = traits->green = traits->blue = traits->alpha = 8;
        traits->depth = 24;
        osg::ref_ptr<osg::GraphicsContext> context = osg::GraphicsContext::createGraphicsContext(traits.get());
        if (!context) throw std::runtime_error("no OpenGL pbuffer (run under an X server: xvfb-run)");

        osgViewer::Viewer viewer;
        viewer.setThreadingModel(osgViewer::Viewer::SingleThreaded);
        osg::Camera* camera = viewer.getCamera();
        camera->setGraphicsContext(context.get());
        camera->setViewport(0, 0, o.width, o.height);
        camera->setDrawBuffer(GL_FRONT);
        camera->setReadBuffer(GL_FRONT);
        camera->setClearColor(osg::Vec4(0.62f, 0.74f, 0.90f, 1.0f));
        camera->setProjectionMatrixAsPerspective(o.fovDeg, double(o.width) / double(o.height), 0.1, 1000.0);
        camera->setViewMatrixAsLookAt(o.eye, o.target, osg::Vec3d(0.0, 1.0, 0.0));
        osg::ref_ptr<FinishCallback> finish = new FinishCallback;
        camera->setFinalDrawCallback(finish.get());
        osg::ref_ptr<osg::Image> image;
        if (!o.png.empty()) {
            image = new osg::Image;
            camera->attach(osg::Camera::COLOR_BUFFER, image.get());
        }
        viewer.setSceneData(shadowed.get());
        viewer.realize();

        std::vector<double> ms;
        for (int i = 0; i < o.warmup + o.frames; ++i) {
            const auto start = std::chrono::steady_clock::now();
            viewer.frame();
            const double elapsed = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
            if (i >= o.warmup) ms.push_back(elapsed);
        }
        std::printf("renderer: %s\n", finish->renderer.c_str());
        std::printf("osgShadow::ShadowMap frame%s: %dx%d, %d^2 map, median of %d frame(s) after %d warm-up: %.3f ms "
                    "(min %.3f, max %.3f)\n",
                    o.perPixel ? " (per-pixel shading)" : "", o.width, o.height, o.map, o.frames, o.warmup, median(ms), *std::min_element(ms.begin(), ms.end()),
                    *std::max_element(ms.begin(), ms.end()));
        if (image && !osgDB::writeImageFile(*image, o.png)) throw std::runtime_error(o.png + ": could not write it");
    } catch (const std::exception& e) {
        std::fprintf(stderr, "osgshadow_peer: error: %s\n", e.what());
        return 1;
    }
    return 0;
}
