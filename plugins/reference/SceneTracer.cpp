#include "SceneTracer.h"

#include "penumbra/core/Digest.h"
#include "penumbra/core/Error.h"

#include <fmt/format.h>

#if defined(__SSE__)
#include <xmmintrin.h>
#endif

#include <algorithm>
#include <cmath>

namespace penumbra::reference {

// ---------------------------------------------------------------------------------------
// Denormals

#if defined(__SSE__)
// MXCSR bits: flush-to-zero (15) and denormals-are-zero (6).
constexpr unsigned kFlushDenormals = 0x8040;
DenormalsAreZero::DenormalsAreZero() : saved_(_mm_getcsr()) { _mm_setcsr(saved_ | kFlushDenormals); }
DenormalsAreZero::~DenormalsAreZero() { _mm_setcsr(saved_); }
#else
DenormalsAreZero::DenormalsAreZero() = default;
DenormalsAreZero::~DenormalsAreZero() = default;
#endif

// ---------------------------------------------------------------------------------------
// Alpha at a hit, as the raster path computes it (shaders/engine/gbuffer.frag): the
// material's alpha times the base-colour texture's, sampled bilinearly with repeat
// wrapping (render/SceneGpu.cpp's sampler; the texture has one level and its alpha is
// linear).

struct SurfaceAlpha {
    const scene::Mesh* mesh = nullptr;
    const scene::Material* material = nullptr;
    const scene::Texture* texture = nullptr;  // null: untextured

    float textureAlpha(glm::vec2 uv) const
    {
        if (!texture) return 1.0f;
        const auto w = int64_t(texture->width), h = int64_t(texture->height);
        // Texel centres at (i + 0.5) / w: the Vulkan linear filter's footprint.
        const double x = double(uv.x) * double(w) - 0.5, y = double(uv.y) * double(h) - 0.5;
        if (!std::isfinite(x) || !std::isfinite(y)) return 1.0f;
        const double x0 = std::floor(x), y0 = std::floor(y);
        const double fx = x - x0, fy = y - y0;
        const auto wrap = [](double i, int64_t n) {
            const int64_t k = int64_t(std::fmod(i, double(n)));
            return k < 0 ? k + n : k;
        };
        const int64_t xs[2] = {wrap(x0, w), wrap(x0 + 1.0, w)};
        const int64_t ys[2] = {wrap(y0, h), wrap(y0 + 1.0, h)};
        const auto alpha = [&](int64_t ix, int64_t iy) {
            return double(texture->rgba[size_t(4 * (iy * w + ix) + 3)]) / 255.0;
        };
        const double top = (1.0 - fx) * alpha(xs[0], ys[0]) + fx * alpha(xs[1], ys[0]);
        const double bottom = (1.0 - fx) * alpha(xs[0], ys[1]) + fx * alpha(xs[1], ys[1]);
        return float((1.0 - fy) * top + fy * bottom);
    }

    // Embree's barycentrics: the hit is (1 - u - v) v0 + u v1 + v v2.
    float alphaAt(uint32_t triangle, float u, float v) const
    {
        const uint32_t* index = &mesh->indices[size_t(3) * triangle];
        const glm::vec2 uv = (1.0f - u - v) * mesh->vertices[index[0]].uv + u * mesh->vertices[index[1]].uv +
                             v * mesh->vertices[index[2]].uv;
        return material->baseColor.a * textureAlpha(uv);
    }
};

namespace {

// The intersection context a filter callback receives: Embree's, then ours.
struct TraceContext {
    RTCIntersectContext embree;
    RayScratch* scratch;
};
static_assert(offsetof(TraceContext, embree) == 0, "filters cast Embree's context pointer back to TraceContext");

// Occlusion filter of alpha-masked and translucent meshes. Rejecting a hit (valid = 0)
// makes Embree go on looking; an accepted one ends the ray as occluded.
void translucencyFilter(const RTCFilterFunctionNArguments* args)
{
    const auto* surface = static_cast<const SurfaceAlpha*>(args->geometryUserPtr);
    auto* context = reinterpret_cast<TraceContext*>(args->context);
    for (unsigned i = 0; i < args->N; ++i) {
        if (args->valid[i] == 0) continue;
        const float alpha = surface->alphaAt(RTCHitN_primID(args->hit, args->N, i), RTCHitN_u(args->hit, args->N, i),
                                             RTCHitN_v(args->hit, args->N, i));
        if (surface->material->alphaMode == scene::AlphaMode::Mask) {
            if (alpha < surface->material->alphaCutoff) args->valid[i] = 0;  // a hole
            continue;
        }
        const float transmittance = 1.0f - std::clamp(alpha, 0.0f, 1.0f);
        if (!(transmittance > 0.0f)) continue;  // opaque here: the ray ends
        context->scratch->crossings.push_back(
            {RTCHitN_instID(args->hit, args->N, i, 0), RTCRayN_tfar(args->ray, args->N, i), transmittance});
        args->valid[i] = 0;
    }
}

const char* embreeErrorName(RTCError error)
{
    switch (error) {
    case RTC_ERROR_NONE: return "no error";
    case RTC_ERROR_UNKNOWN: return "unknown error";
    case RTC_ERROR_INVALID_ARGUMENT: return "invalid argument";
    case RTC_ERROR_INVALID_OPERATION: return "invalid operation";
    case RTC_ERROR_OUT_OF_MEMORY: return "out of memory";
    case RTC_ERROR_UNSUPPORTED_CPU: return "unsupported CPU";
    case RTC_ERROR_CANCELLED: return "cancelled";
    }
    return "unrecognised error";
}

} // namespace

// ---------------------------------------------------------------------------------------
// SceneTracer

SceneTracer::SceneTracer(const scene::Scene& scene) : scene_(scene)
{
    const DenormalsAreZero denormals;
    device_ = rtcNewDevice(nullptr);
    if (!device_)
        throw Error(fmt::format("reference: Embree could not create a device: {}",
                                embreeErrorName(rtcGetDeviceError(nullptr))));
    try {
        top_ = rtcNewScene(device_);
        checkDevice("creating the top-level scene");
        // Robust: no arithmetic shortcuts that could let a ray slip through an edge shared
        // by two triangles; the reference must not leak light.
        rtcSetSceneFlags(top_, RTC_SCENE_FLAG_ROBUST);
        meshScenes_.assign(scene.meshes.size(), nullptr);
        surfaces_.resize(scene.meshes.size());
        for (size_t m = 0; m < scene.meshes.size(); ++m) {
            const scene::Mesh& mesh = scene.meshes[m];
            core::Digest128 hash;
            if (mesh.material >= scene.materials.size())
                throw Error(fmt::format("reference: mesh '{}': material {} does not exist ({} materials)", mesh.name,
                                        mesh.material, scene.materials.size()));
            const scene::Material& material = scene.materials[mesh.material];
            auto surface = std::make_unique<SurfaceAlpha>();
            surface->mesh = &mesh;
            surface->material = &material;
            if (material.baseColorTexture != scene::kNoTexture) {
                if (size_t(material.baseColorTexture) >= scene.textures.size())
                    throw Error(fmt::format("reference: material '{}': texture {} does not exist", material.name,
                                            material.baseColorTexture));
                const scene::Texture& texture = scene.textures[size_t(material.baseColorTexture)];
                if (texture.width == 0 || texture.height == 0 ||
                    texture.rgba.size() != size_t(4) * texture.width * texture.height)
                    throw Error(fmt::format("reference: texture '{}': {} bytes for {} x {} RGBA8 texels", texture.name,
                                            texture.rgba.size(), texture.width, texture.height));
                surface->texture = &texture;
            }
            const bool seeThrough = material.alphaMode != scene::AlphaMode::Opaque;
            hash.value(material.alphaMode);
            if (seeThrough) {
                hash.value(material.alphaCutoff);
                hash.value(material.baseColor.a);
                if (surface->texture) {
                    hash.value(surface->texture->width);
                    hash.value(surface->texture->height);
                    hash.bytes(surface->texture->rgba.data(), surface->texture->rgba.size());
                }
            }
            const size_t triangles = mesh.indices.size() / 3;
            for (const scene::Vertex& v : mesh.vertices) {
                hash.value(v.position);
                if (seeThrough) hash.value(v.uv);
            }
            hash.bytes(mesh.indices.data(), triangles * 3 * sizeof(uint32_t));
            meshDigests_.push_back(hash.finish());
            surfaces_[m] = std::move(surface);
            if (triangles == 0) continue;
            for (size_t i = 0; i < triangles * 3; ++i)
                if (mesh.indices[i] >= mesh.vertices.size())
                    throw Error(fmt::format("reference: mesh '{}': index {} is {}, but the mesh has {} vertices",
                                            mesh.name, i, mesh.indices[i], mesh.vertices.size()));

            RTCGeometry geometry = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
            checkDevice("creating a triangle mesh");
            // Embree pads the buffers it allocates as its SIMD loads need.
            auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(
                geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), mesh.vertices.size()));
            auto* indices = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(
                geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(uint32_t), triangles));
            if (!vertices || !indices) {
                rtcReleaseGeometry(geometry);
                checkDevice(fmt::format("allocating the buffers of mesh '{}'", mesh.name).c_str());
            }
            for (size_t v = 0; v < mesh.vertices.size(); ++v)
                std::copy_n(&mesh.vertices[v].position.x, 3, vertices + 3 * v);
            std::copy_n(mesh.indices.data(), triangles * 3, indices);
            if (seeThrough) {
                rtcSetGeometryUserData(geometry, surfaces_[m].get());
                rtcSetGeometryOccludedFilterFunction(geometry, translucencyFilter);
            }
            rtcCommitGeometry(geometry);
            RTCScene meshScene = rtcNewScene(device_);
            rtcSetSceneFlags(meshScene, RTC_SCENE_FLAG_ROBUST);
            rtcAttachGeometry(meshScene, geometry);
            rtcReleaseGeometry(geometry);
            rtcCommitScene(meshScene);
            meshScenes_[m] = meshScene;
            checkDevice(fmt::format("building the BVH of mesh '{}'", mesh.name).c_str());
        }
        for (uint32_t i = 0; i < scene.instances.size(); ++i) attachInstance(i);
        rtcCommitScene(top_);
        checkDevice("building the top-level BVH");
        updateDigest();
    } catch (...) {
        for (RTCScene s : meshScenes_)
            if (s) rtcReleaseScene(s);
        if (top_) rtcReleaseScene(top_);
        rtcReleaseDevice(device_);
        throw;
    }
}

SceneTracer::~SceneTracer()
{
    rtcReleaseScene(top_);
    for (RTCScene s : meshScenes_)
        if (s) rtcReleaseScene(s);
    rtcReleaseDevice(device_);
}

void SceneTracer::checkDevice(const char* what) const
{
    const RTCError error = rtcGetDeviceError(device_);
    if (error != RTC_ERROR_NONE) throw Error(fmt::format("reference: Embree failed {}: {}", what, embreeErrorName(error)));
}

// Instance i of the scene is geometry i of the top-level scene, so that a hit's instID is
// the scene's instance index. Instances of meshes without triangles are left out.
void SceneTracer::attachInstance(uint32_t instance)
{
    const uint32_t mesh = scene_.instances[instance].mesh;
    if (mesh >= meshScenes_.size())
        throw Error(fmt::format("reference: instance {}: mesh {} does not exist", instance, mesh));
    if (!meshScenes_[mesh]) return;
    RTCGeometry geometry = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_INSTANCE);
    checkDevice("creating an instance");
    rtcSetGeometryInstancedScene(geometry, meshScenes_[mesh]);
    rtcAttachGeometryByID(top_, geometry, instance);
    rtcReleaseGeometry(geometry);
    setTransform(instance);
}

void SceneTracer::setTransform(uint32_t instance)
{
    RTCGeometry geometry = rtcGetGeometry(top_, instance);
    if (!geometry) return;
    const glm::mat4& m = scene_.instanceTransform(scene_.instances[instance]);
    bool finite = true;
    for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 4; ++r) finite = finite && std::isfinite(m[c][r]);
    // A transform Embree cannot invert (or a non-finite one) would poison the BVH: such
    // an instance casts no shadow, as it has no surface either.
    if (!finite || glm::determinant(glm::mat3(m)) == 0.0f) {
        rtcDisableGeometry(geometry);
    } else {
        rtcSetGeometryTransform(geometry, 0, RTC_FORMAT_FLOAT4X4_COLUMN_MAJOR, &m[0][0]);
        rtcEnableGeometry(geometry);
    }
    rtcCommitGeometry(geometry);
}

void SceneTracer::refit(std::span<const uint32_t> instances)
{
    if (instances.empty()) return;
    const DenormalsAreZero denormals;
    for (uint32_t i : instances) {
        if (i >= scene_.instances.size())
            throw Error(fmt::format("reference: moved instance {} does not exist ({} instances)", i,
                                    scene_.instances.size()));
        setTransform(i);
    }
    // The top level holds one box per instance: rebuilding it is cheap, and the meshes'
    // own BVHs are untouched.
    rtcCommitScene(top_);
    checkDevice("rebuilding the top-level BVH after instances moved");
    updateDigest();
}

void SceneTracer::updateDigest()
{
    core::Digest128 hash;
    for (const scene::Instance& instance : scene_.instances) {
        hash.value(meshDigests_[instance.mesh]);
        hash.value(scene_.instanceTransform(instance));
    }
    digest_ = hash.finish();
    sceneRadius_ = scene_.bounds().radius();
}

float SceneTracer::transmittance(const glm::vec3& origin, const glm::vec3& direction, float length,
                                 float sameSurface, RayScratch& scratch) const
{
    if (!(length > 0.0f)) return 1.0f;
    TraceContext context;
    rtcInitIntersectContext(&context.embree);
    context.scratch = &scratch;
    scratch.crossings.clear();
    RTCRay ray{};
    ray.org_x = origin.x;
    ray.org_y = origin.y;
    ray.org_z = origin.z;
    ray.dir_x = direction.x;
    ray.dir_y = direction.y;
    ray.dir_z = direction.z;
    ray.tnear = 0.0f;
    ray.tfar = length;
    ray.mask = ~0u;
    rtcOccluded1(top_, &context.embree, &ray);
    if (ray.tfar < 0.0f) return 0.0f;  // Embree marks an occluded ray with tfar = -inf
    std::vector<Crossing>& crossings = scratch.crossings;
    if (crossings.empty()) return 1.0f;
    // The product in a fixed order (by instance, then distance), whatever order the
    // traversal found the crossings in: bit-identical results on any thread count.
    std::sort(crossings.begin(), crossings.end(), [](const Crossing& a, const Crossing& b) {
        return a.instance != b.instance ? a.instance < b.instance : a.distance < b.distance;
    });
    float transmittance = 1.0f;
    for (size_t i = 0; i < crossings.size(); ++i) {
        const bool repeat = i > 0 && crossings[i].instance == crossings[i - 1].instance &&
                            crossings[i].distance - crossings[i - 1].distance <= sameSurface;
        if (!repeat) transmittance *= crossings[i].transmittance;
    }
    return std::clamp(transmittance, 0.0f, 1.0f);
}

} // namespace penumbra::reference
