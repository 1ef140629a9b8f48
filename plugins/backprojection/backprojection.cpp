// Soft shadows by back-projection (Guennebaud, Barthe, Paulin 2007; Yang, Feng,
// Guennebaud, Liu 2009, "Packet-based hierarchal soft shadow mapping"; README.md next to
// this file): the occluders' contour in the light's shadow map, extracted by marching
// squares over the samples that can hide part of the light from a receiver, is
// back-projected onto the light and the hidden area integrated exactly.
// Passes (paper Algorithm 1): the engine's shadow map (render/ShadowMap.h, step 3), its
// multi-scale shadow map (mssm.comp, mssm.glsl: step 4), with packets the packet pass
// (packets.comp: steps 6 and 7) and the per-pixel visibility (visibility.comp: steps 5
// and 8; contour.glsl holds what both do). The MSSM and the packets' results are
// transient graph images. With S x S sub-lights (step 2, §5) each sub-light runs those
// passes in turn and adds its share to V; with two depth layers (§5's alternative) a
// peeled second map and its MSSM join the first, and V counts what either hides.
#include "penumbra/core/Error.h"
#include "penumbra/gpu/Barrier.h"
#include "penumbra/gpu/Context.h"
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/gpu/Resources.h"
#include "penumbra/graph/PassContext.h"
#include "penumbra/graph/RenderGraph.h"
#include "penumbra/plugin/ClearPass.h"
#include "penumbra/plugin/ComputePipeline.h"
#include "penumbra/plugin/DebugViews.h"
#include "penumbra/plugin/GBuffer.h"
#include "penumbra/plugin/Plugin.h"
#include "penumbra/plugin/ShadowMapParams.h"
#include "penumbra/plugin/Technique.h"
#include "penumbra/plugin/VisibilityPass.h"
#include "penumbra/render/ShadowMap.h"

#include <fmt/format.h>
#include <glm/glm.hpp>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <iterator>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace penumbra::backprojection {
namespace {

using plugin::ParamType;

// Parameter `traversal`: visibility.comp's TRAVERSAL.
enum class Traversal : uint32_t { Flat, Hierarchical };
constexpr const char* kTraversalNames[] = {"flat", "hierarchical"};

// Parameter `packet`: PACKET, the packet's side in pixels (§4.1), in choice order.
constexpr const char* kPacketNames[] = {"1x1", "2x2", "3x3", "4x4"};

// Parameter `coherence`: packets.comp's pc.classify.
enum class Coherence : uint32_t { Model, Always };
constexpr const char* kCoherenceNames[] = {"model", "always"};

// The debug images the debug_views pass writes (visibility.comp DEBUG_IMAGES), each
// io.local(name): requested by name, else the pass is culled and costs nothing.
constexpr plugin::DebugImage kDebugImages[] = {
    {"kernel", "kernelOut"}, {"visited", "visitedOut"}, {"coherence", "coherenceOut"}};

// packets.comp's result per pixel: (V or -1, class, reads, kernel side).
constexpr VkFormat kPacketsFormat = VK_FORMAT_R32G32B32A32_SFLOAT;

// visibility.comp's MAX_LEVELS: the traversal's stack is sized for it.
constexpr int kMaxLevels = 14;

// llvmpipe stops a shader invocation's loops after 65,535 iterations in all (gallivm's
// loop limiter, LP_MAX_TGSI_LOOP_ITERATIONS, shared by every loop and counted per SIMD
// group: docs/plugins.md, "Shaders"), silently. One receiver's walk of a k x k kernel
// iterates once per node popped (flat: once per block and row; hierarchical: at most
// 4/3 k² + 8 k nodes, four children pushed per node that meets the kernel) and four
// times per block it reads (contour.glsl processCell's sides), so at most
// (4/3 + 4) k² + 8 k + the setup's few dozen: inside the count for k <= 109. On a CPU
// device the cap stops at 104 (5% margin).
constexpr int kCpuMaxKernel = 104;
// With two depth layers each receiver walks twice in one invocation: 2 ((4/3 + 4) k² +
// 8 k) + the setup's few dozen stay inside the count for k <= 77; 73 with the same margin.
constexpr int kCpuMaxKernelTwoLayers = 73;
// The loop iterations packets.comp lets a packet's walk run on a CPU device (the rest of
// the 65,535 for the pass's own loops); elsewhere no limit.
constexpr int32_t kCpuPacketLoopBudget = 60000;
constexpr int32_t kUnlimitedLoops = 1 << 30;

// Parameter `sub_lights`: S of §5, at most 4 (16 shadow maps and MSSMs a frame: the maps
// and MSSMs, not the walks, then cost the most).
constexpr int kMaxSubLights = 4;
// Parameter `layers`: the depth-peeled layers, at most two (visibility.comp LAYERS).
constexpr int kMaxLayers = 2;

// Q_e and Q_v of eq. 6 (Q_n = 1): README, "Packets", gives the sweep.
constexpr double kDefaultEdgeCost = 16.0;
constexpr double kDefaultVisibilityCost = 4.0;
// T_d of eq. 5: 1 turns eq. 5 off (README, "Packets": the paper's 0.8 sent 93-97% of the
// walkers to per-pixel walks here, where walked as one 2.4-3.6% meet a null status).
constexpr double kDefaultDivergenceThreshold = 1.0;
// The packet size (kPacketNames' index): 1 x 1. 3 x 3 packets were 1.16-1.57x faster
// under the packet bench's sun and 1.23x slower on config/default.json's spot (README,
// "Packets"): per pixel is never the slower here.
constexpr double kDefaultPacket = 0;

const plugin::ParamSpec kParams[] = {
    // 512: a 1024-texel cube atlas's MSSM (384 MiB) takes seconds to build on lavapipe
    // (README, "Memory").
    plugin::shadowResolutionParam(512, 4096),
    {"light_size", ParamType::Float, -1, -1, 1e9, "world or deg",
     "-1: the light's own shape (rect, disk, a point light's sphere, a directional light's angular diameter; a spot "
     "light has none: a hard shadow); >= 0: instead a square of this side facing along the spot's axis or in the rect's "
     "plane, a disk or sphere of this diameter, or a sun of this angular diameter in degrees"},
    {"traversal", ParamType::Enum, double(Traversal::Hierarchical), 0, 0, "",
     "flat: every 2 x 2 block of samples in the kernel ([GBP07] with MSSM kernels); hierarchical: the MSSM descended "
     "from the kernel's corner, pruning blocks that hold no contour (Yang et al. 2009, 4.2): the same edges",
     kTraversalNames, uint32_t(std::size(kTraversalNames))},
    {"packet", ParamType::Enum, kDefaultPacket, 0, 0, "",
     "pixels that share one kernel walk (Yang et al. 2009, 4.1): 1x1 is per pixel; a packet that the cost model or "
     "a diverging contour (the null status) rules out walks per pixel, so every size gives the same image",
     kPacketNames, uint32_t(std::size(kPacketNames))},
    {"coherence", ParamType::Enum, double(Coherence::Model), 0, 0, "",
     "model: a packet walks as one where eq. 5 and eq. 6 (divergence_threshold, edge_cost, visibility_cost) expect "
     "it to pay; always: every packet does (only a null status met in the walk, and on a CPU device its loop budget, "
     "send its pixels to their own walks)",
     kCoherenceNames, uint32_t(std::size(kCoherenceNames))},
    {"edge_cost", ParamType::Float, kDefaultEdgeCost, 0, 1e6, "Q_n",
     "Q_e of eq. 6: extracting an edge, in units of visiting a node (Q_n = 1); with visibility_cost it prices a "
     "packet walk against its pixels' own (README, \"Packets\": the sweep that chose the default)"},
    {"visibility_cost", ParamType::Float, kDefaultVisibilityCost, 0, 1e6, "Q_n",
     "Q_v of eq. 6: back-projecting and integrating an edge for one receiver, in units of visiting a node"},
    {"divergence_threshold", ParamType::Float, kDefaultDivergenceThreshold, 0, 1, "",
     "T_d of eq. 5: a packet whose estimated probability of diverging contours exceeds it walks per pixel (1: only "
     "the cost model and the null status met in the walk decide)"},
    {"sub_lights", ParamType::Int, 1, 1, kMaxSubLights, "S",
     "multi-view shadow maps (Yang et al. 2009, 5): the light's rectangle (a rect light's, or the square of a spot "
     "light's light_size) split into S x S equal sub-lights, each with its own shadow map and MSSM drawn from its "
     "centre (the graph reuses one allocation for all), V their average: an occluder that the light's centre does "
     "not see still shadows, for S^2 maps and MSSMs. A light without size uses one map; a disk, sphere or sun light "
     "takes only 1"},
    {"layers", ParamType::Int, 1, 1, kMaxLayers, "",
     "depth-peeled shadow-map layers (the multi-layer alternative Yang et al. 2009, 5 compare with sub_lights: "
     "Bavoil et al. 2008, Schwarz and Stamminger 2007): 2 adds a second map of the nearest surfaces behind the "
     "first, with its own MSSM and kernels, and V counts the light either layer hides once (their overlap from "
     "16 x 16 light samples), so an occluder hidden behind another from the light's centre still shadows. Walks "
     "per pixel (packet 1x1) with one view (sub_lights 1)"},
    plugin::kernelLimitParam("max_kernel", 0.0625,
                             "the kernel cap: the largest side of a receiver's kernel, a fraction of the face's side "
                             "(occluders beyond it are not seen; it bounds the work of an occluder near the light)"),
    plugin::kShadowDepthBiasParam,
};

struct Settings {
    uint32_t resolution = 512;
    float lightSizeOverride = -1.0f;
    Traversal traversal = Traversal::Hierarchical;
    int packet = int(kDefaultPacket) + 1;  // pixels per side
    Coherence coherence = Coherence::Model;
    float edgeCost = float(kDefaultEdgeCost);
    float visibilityCost = float(kDefaultVisibilityCost);
    float divergenceThreshold = float(kDefaultDivergenceThreshold);
    int subLights = 1;   // S
    int layers = 1;
    int maxKernel = 64;  // cells per side
    float depthBias = 4.0f;
};

Settings readSettings(const plugin::ParamValues& params)
{
    Settings s;
    s.resolution = uint32_t(params.getInt("resolution"));
    s.lightSizeOverride = plugin::lightSizeOverride(params, "backprojection");
    s.traversal = Traversal(params.getEnumIndex("traversal"));
    s.packet = int(params.getEnumIndex("packet")) + 1;
    s.coherence = Coherence(params.getEnumIndex("coherence"));
    s.edgeCost = params.getFloat("edge_cost");
    s.visibilityCost = params.getFloat("visibility_cost");
    s.divergenceThreshold = params.getFloat("divergence_threshold");
    s.subLights = params.getInt("sub_lights");
    s.layers = params.getInt("layers");
    s.maxKernel = std::max(1, int(std::ceil(plugin::kernelLimitTexels(params.getFloat("max_kernel"), s.resolution))));
    s.depthBias = params.getFloat("depth_bias");
    return s;
}

// MSSM levels so that 2^(levels - 1) >= maxKernel: the node that covers a kernel exists.
int mssmLevels(int maxKernel)
{
    return maxKernel > 1 ? int(std::bit_width(uint32_t(maxKernel - 1))) + 1 : 1;
}

// The MSSM image (mssm.glsl): the levels stacked downwards, RG32F.
constexpr VkFormat kMssmFormat = VK_FORMAT_R32G32_SFLOAT;
VkDeviceSize mssmBytes(uint32_t width, uint32_t height, int levels)
{
    return VkDeviceSize(width) * height * VkDeviceSize(levels) * 2 * sizeof(float);
}

// visibility.comp's FaceFrame and BackprojectionLight (std430).
struct FaceFrame {
    glm::vec4 base0{0.0f}, baseU{0.0f}, baseV{0.0f}, dir0{0.0f}, dirU{0.0f}, dirV{0.0f};
};
struct LightData {
    glm::vec4 centre{0.0f};
    glm::vec4 normal{0.0f};
    glm::vec4 tangent{0.0f};
    glm::vec4 bitangent{0.0f};
    glm::vec4 extent{0.0f};
    FaceFrame faces[render::kMaxShadowFaces];
};
static_assert(sizeof(LightData) == 5 * 16 + render::kMaxShadowFaces * 96, "std430 layout of visibility.comp");

struct VisibilityPush {
    int32_t levels = 1;
    int32_t maxKernel = 1;
    float edgeCost = 0.0f;
    float visibilityCost = 0.0f;
    float divergenceThreshold = 0.0f;
    int32_t loopBudget = 0;
    int32_t classify = 1;
};

struct MssmPush {
    glm::ivec2 atlasSize{0};
    int32_t faceTexels = 0;
    int32_t level = 0;
    int32_t base = 0;  // the depth layer's first array layer (mssm.glsl)
};

// An orthonormal frame (t, b) with t x b = n.
void frameAround(const glm::dvec3& n, glm::dvec3& t, glm::dvec3& b)
{
    t = glm::normalize(glm::cross(n, std::abs(n.y) < 0.9 ? glm::dvec3(0.0, 1.0, 0.0) : glm::dvec3(1.0, 0.0, 0.0)));
    b = glm::cross(n, t);
}

glm::dvec3 unitOr(const glm::vec3& v, const glm::dvec3& fallback)
{
    const glm::dvec3 d(v);
    const double len = glm::length(d);
    return len > 0.0 && std::isfinite(len) ? d / len : fallback;
}

// The light's shape on its plane (visibility.comp lightPlaneFor), from the light and the
// technique's light_size.
LightData lightShape(const scene::Light& light, float overrideSize)
{
    LightData d;
    const double size = overrideSize >= 0.0f ? double(overrideSize) : -1.0;
    glm::dvec3 n = unitOr(light.direction, {0.0, -1.0, 0.0}), t, b;
    frameAround(n, t, b);
    glm::dvec4 extent(0.0);
    switch (light.type) {
    case scene::LightType::Spot: extent = {0.5 * std::max(size, 0.0), 0.5 * std::max(size, 0.0), 0.0, 0.0}; break;
    case scene::LightType::Rect: {
        // The config makes the tangent unit and normal to the direction; make sure.
        const glm::dvec3 tangent = glm::dvec3(light.tangent) - glm::dot(glm::dvec3(light.tangent), n) * n;
        if (glm::length(tangent) > 1e-6) {
            t = glm::normalize(tangent);
            b = glm::cross(n, t);
        }
        extent = size >= 0.0 ? glm::dvec4(0.5 * size, 0.5 * size, 0.0, 0.0)
                             : glm::dvec4(0.5 * std::max(double(light.sizeWorld.x), 0.0),
                                          0.5 * std::max(double(light.sizeWorld.y), 0.0), 0.0, 0.0);
        break;
    }
    case scene::LightType::Disk:
        extent = {size >= 0.0 ? 0.5 * size : std::max(double(light.radiusWorld), 0.0), 0.0, 1.0, 0.0};
        break;
    case scene::LightType::Point:
        // The outline's radius is the shader's, per receiver; x only says "has a size".
        extent = {0.0, 0.0, 1.0, size >= 0.0 ? 0.5 * size : std::max(double(light.radiusWorld), 0.0)};
        extent.x = extent.w;
        break;
    case scene::LightType::Directional: {
        // The sun's disk of directions on the plane one unit towards it: radius
        // tan(angular radius), the diameter clamped below 179 degrees.
        n = -n;
        frameAround(n, t, b);
        const double degrees = std::clamp(size >= 0.0 ? size : double(light.angularDiameterDeg), 0.0, 179.0);
        extent = {std::tan(0.5 * degrees * std::numbers::pi / 180.0), 0.0, 1.0, 0.0};
        break;
    }
    }
    d.centre = glm::vec4(glm::vec3(light.position), 1.0f);
    d.normal = glm::vec4(glm::vec3(n), 0.0f);
    d.tangent = glm::vec4(glm::vec3(t), 0.0f);
    d.bitangent = glm::vec4(glm::vec3(b), 0.0f);
    d.extent = glm::vec4(extent);
    return d;
}

// The size render::softShadowKernelReach measures the PCSS framework's reach with, that
// bounds this light's kernels: its widest extent (a spot's or rect's diagonal, a disk's
// diameter, 2 tan(θ/2) of a sun); a sphere's outline grows without bound near it.
float reachSize(const LightData& d, scene::LightType type)
{
    const glm::vec4 e = d.extent;
    switch (type) {
    case scene::LightType::Spot:
    case scene::LightType::Rect: return 2.0f * std::sqrt(e.x * e.x + e.y * e.y);
    case scene::LightType::Disk:
    case scene::LightType::Directional: return 2.0f * e.x;
    case scene::LightType::Point: return e.w > 0.0f ? std::numeric_limits<float>::infinity() : 0.0f;
    }
    return 0.0f;
}

// Whether §5's S x S split applies: a rectangle with an area (a rect light's, a spot
// light's light_size square). A disk, a sphere's outline or a sun's disk of directions
// has no split into equal rectangles that light_area.glsl integrates.
bool hasRectangle(const LightData& d, scene::LightType type)
{
    const bool rectangle = type == scene::LightType::Rect || type == scene::LightType::Spot;
    return rectangle && d.extent.x > 0.0f && d.extent.y > 0.0f;
}

// Sub-light (i, j) of the S x S split of `whole` (lightShape of `light`; hasRectangle):
// the cell's rectangle, and the light moved to the cell's centre in the light's plane
// (a rect light's size the cell's, so that its map's horizon test sees the cell; a spot
// light keeps its cone).
struct SubLight {
    scene::Light light;
    LightData shape;
};
SubLight subLight(const scene::Light& light, const LightData& whole, int s, int i, int j)
{
    const glm::dvec2 half = glm::dvec2(whole.extent) / double(s);
    const glm::dvec2 offset = (glm::dvec2(i, j) + 0.5) * 2.0 * half - glm::dvec2(whole.extent);
    const glm::dvec3 centre = glm::dvec3(whole.centre) + offset.x * glm::dvec3(whole.tangent) +
                              offset.y * glm::dvec3(whole.bitangent);
    SubLight sub{light, whole};
    sub.shape.centre = glm::vec4(glm::vec3(centre), 1.0f);
    sub.shape.extent = glm::vec4(float(half.x), float(half.y), 0.0f, 0.0f);
    sub.light.position = glm::vec3(centre);
    if (light.type == scene::LightType::Rect) sub.light.sizeWorld = glm::vec2(2.0 * half);
    return sub;
}

// Face uv (u, v) and distance along the face's axis back to the world, as the shader's
// FaceFrame: linear in u, v and (for each) in the distance. From two depths at each of
// three uvs, unprojected in double precision.
FaceFrame faceFrame(const render::ShadowFaceData& face)
{
    const glm::dmat4 inverse = glm::inverse(glm::dmat4(face.viewProj));
    const glm::dvec4 range(face.depthRange);
    const bool orthographic = range.z != 0.0;
    // shaders/common/shadow_map.glsl shadowDistanceInRange.
    const auto distance = [&](double ndc) {
        return orthographic ? range.y + (range.x - range.y) * ndc : range.x / std::max(ndc, range.x / range.y);
    };
    const auto point = [&](glm::dvec2 uv, double ndc) {
        const glm::dvec4 h = inverse * glm::dvec4(uv * 2.0 - 1.0, ndc, 1.0);
        return glm::dvec3(h) / h.w;
    };
    const double ndcA = 1.0, ndcB = 0.5;
    const double da = distance(ndcA), db = distance(ndcB);
    FaceFrame f;
    glm::dvec3 base[3], dir[3];
    const glm::dvec2 uvs[3] = {{0.0, 0.0}, {1.0, 0.0}, {0.0, 1.0}};
    for (int i = 0; i < 3; ++i) {
        const glm::dvec3 a = point(uvs[i], ndcA), b = point(uvs[i], ndcB);
        dir[i] = db != da ? (b - a) / (db - da) : glm::dvec3(0.0);
        base[i] = a - da * dir[i];
    }
    const auto finite = [](const glm::dvec3& v) {
        return glm::vec4(glm::vec3(std::isfinite(v.x + v.y + v.z) ? v : glm::dvec3(0.0)), 0.0f);
    };
    f.base0 = finite(base[0]);
    f.baseU = finite(base[1] - base[0]);
    f.baseV = finite(base[2] - base[0]);
    f.dir0 = finite(dir[0]);
    f.dirU = finite(dir[1] - dir[0]);
    f.dirV = finite(dir[2] - dir[0]);
    return f;
}

// S of the split the light takes: sub_lights where it has a rectangle, else 1 (a light
// without size casts the hard shadow one map gives); a disk, sphere or sun is refused.
int splitFor(const scene::Light& light, const LightData& whole, int subLights)
{
    if (subLights == 1 || hasRectangle(whole, light.type)) return subLights;
    if (light.type != scene::LightType::Rect && light.type != scene::LightType::Spot) {
        throw ConfigError(fmt::format("backprojection: sub_lights: {} x {} sub-lights split a rectangular light (a "
                                      "rect light, or a spot light with light_size > 0); a {} light's shape has no "
                                      "such split here: set sub_lights to 1",
                                      subLights, subLights, scene::lightTypeName(light.type)));
    }
    return 1;
}

// The depth layers the light takes: `layers`, or 1 for a light without size (its hard
// compare reads the first map only). Two layers are refused with packets (a packet's
// walk would carry each receiver's light samples) and with sub-lights (the paper
// compares the two; one at a time here).
int layersFor(const scene::Light& light, const LightData& whole, const Settings& s, int split)
{
    if (s.layers == 1) return 1;
    if (s.packet > 1) {
        throw ConfigError(fmt::format("backprojection: layers: {} depth layers walk each pixel alone (the union of "
                                      "the layers needs each receiver's own light samples): set packet to 1x1, not {}",
                                      s.layers, kPacketNames[s.packet - 1]));
    }
    if (split > 1) {
        throw ConfigError(fmt::format("backprojection: layers: {} depth layers take one view of the light: set "
                                      "sub_lights to 1 (it is {}), or layers to 1 for the multi-view maps",
                                      s.layers, split));
    }
    const bool rectangle = light.type == scene::LightType::Rect || light.type == scene::LightType::Spot;
    const bool sized = rectangle ? hasRectangle(whole, light.type) : whole.extent.x > 0.0f;
    return sized ? s.layers : 1;
}

class BackprojectionShadow final : public plugin::Technique {
public:
    explicit BackprojectionShadow(const plugin::TechniqueSetup& setup);

    void update(const scene::Light& light, const scene::Aabb& sceneBounds) override;
    void registerPasses(graph::RenderGraph& graph, const plugin::LightPassIo& io) override;

private:
    // One shadow map's worth: the light's own, or one sub-light's (§5).
    struct View {
        View(const plugin::TechniqueSetup& setup, SubLight first, uint32_t resolution, uint32_t guardTexels,
             const std::string& technique, const std::string& lightBufferName)
            : sub(std::move(first)),
              shadowMap(render::ShadowMapSetup{setup.context, setup.shaders, setup.casters, sub.light,
                                               setup.sceneBounds, setup.lightIndex},
                        resolution, technique, guardTexels),
              lightBuffer(setup.context, sizeof(LightData), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true, lightBufferName)
        {
        }
        SubLight sub;  // the (sub-)light its map is drawn from, and its shape
        render::ShadowMap shadowMap;
        gpu::Buffer lightBuffer;  // LightData: sub.shape and the map's faces
    };
    // A view's graph names: its images, and what its visibility pass writes (V_l for the
    // last view, else the sum so far).
    struct ViewNames {
        std::string map, peeled, mssm, packets, out;  // peeled: the second layer's map, or empty
        std::string prefix;  // of its passes and debug images: "" or "view1."
    };

    std::vector<SubLight> subLights(const scene::Light& light) const;
    void addViewPasses(graph::RenderGraph& graph, const plugin::LightPassIo& io, size_t k);
    void checkDevice() const;
    void writeLight(View& view);
    void recordMssm(const graph::PassContext& pass, const View& view, const ViewNames& names) const;
    void bindVisibility(const graph::PassContext& pass, gpu::DescriptorPush& descriptors, size_t view,
                        const ViewNames& names, const gpu::Pipeline& pipeline) const;
    void recordPackets(const graph::PassContext& pass, const plugin::LightPassIo& io, size_t view,
                       const ViewNames& names) const;
    const render::ShadowMap& firstMap() const { return views_.front()->shadowMap; }
    glm::ivec2 atlasSize() const { return {int(firstMap().atlasWidth()), int(firstMap().atlasHeight())}; }

    gpu::Context& context_;
    Settings settings_;  // maxKernel: the cap the walks run under (on a CPU device, at most its loops' cap)
    int levels_ = 1;
    int32_t loopBudget_ = kUnlimitedLoops;  // packets.comp's
    int split_ = 1;                         // S: sub_lights, or 1 for a light without size
    int layers_ = 1;                        // depth layers: layers, or 1 for a light without size
    // One per sub-light, in row order (S x S where the light has a rectangle, else one),
    // each with its own map, same size and type.
    std::vector<std::unique_ptr<View>> views_;
    gpu::Pipeline mssm_;        // levels 1 and up
    gpu::Pipeline mssmLevel0_;  // level 0, from the depth map
    gpu::Pipeline visibility_;
    std::optional<gpu::Pipeline> packets_;  // with packets larger than 1 x 1
    // The visibility shader with DEBUG_IMAGES, writing every view's debug images.
    std::optional<plugin::DebugViewPass> debugViews_;
    gpu::Sampler compareSampler_;
    gpu::Sampler depthSampler_;
    uint32_t width_ = 0, height_ = 0;  // V_l's
};

BackprojectionShadow::BackprojectionShadow(const plugin::TechniqueSetup& setup)
    : context_(setup.context),
      settings_(readSettings(setup.params)),
      width_(setup.width),
      height_(setup.height)
{
    const LightData whole = lightShape(setup.light, settings_.lightSizeOverride);
    split_ = splitFor(setup.light, whole, settings_.subLights);
    layers_ = layersFor(setup.light, whole, settings_, split_);
    // The cap bounds a walk's cells, not the kernel (a wider kernel is walked on a coarser
    // grid, receiverKernel): on a CPU device it is held to what llvmpipe's loop limit lets
    // one invocation walk, and a wider max_kernel only walks coarser, sooner.
    const int cpuMaxKernel = layers_ > 1 ? kCpuMaxKernelTwoLayers : kCpuMaxKernel;
    if (context_.deviceInfo().type == "cpu" && settings_.maxKernel > cpuMaxKernel) {
        spdlog::info("backprojection (light {}): max_kernel is {} texels at resolution {}; a CPU device walks at most "
                     "{} cells a side{} (llvmpipe stops a shader's loops after 65,535 iterations), so kernels wider "
                     "than {} are walked on a coarser grid",
                     setup.lightIndex, settings_.maxKernel, settings_.resolution, cpuMaxKernel,
                     layers_ > 1 ? fmt::format(" with {} layers", layers_) : "", cpuMaxKernel);
        settings_.maxKernel = cpuMaxKernel;
    }
    levels_ = mssmLevels(settings_.maxKernel);
    if (levels_ > kMaxLevels) {
        throw ConfigError(fmt::format("backprojection: max_kernel: a kernel of {} texels needs {} MSSM levels, more "
                                      "than the traversal holds ({}); lower max_kernel or resolution",
                                      settings_.maxKernel, levels_, kMaxLevels));
    }
    // A kernel reaches half the cap (and its one-cell margin) past a cube edge: its
    // samples lie in the receiver's face.
    const uint32_t guard = render::kernelGuardTexels(0.5f * float(settings_.maxKernel) + 2.0f, settings_.resolution);
    const std::vector<SubLight> subs = subLights(setup.light);
    for (size_t k = 0; k < subs.size(); ++k) {
        const std::string view = subs.size() > 1 ? fmt::format("view{}", k) : "";
        views_.push_back(std::make_unique<View>(setup, subs[k], settings_.resolution, guard,
                                                view.empty() ? "backprojection" : "backprojection." + view,
                                                setup.local(view.empty() ? "light" : view + ".light")));
    }
    checkDevice();
    if (context_.deviceInfo().type == "cpu") loopBudget_ = kCpuPacketLoopBudget;
    mssm_ = plugin::createComputePipeline(setup, "mssm", "mssm.comp", {{"MSSM_LEVEL0", "0"}}, sizeof(MssmPush));
    mssmLevel0_ =
        plugin::createComputePipeline(setup, "mssm_level0", "mssm.comp", {{"MSSM_LEVEL0", "1"}}, sizeof(MssmPush));

    gpu::ComputePipelineDesc c = plugin::computePipelineDesc(
        setup, "visibility", "visibility.comp",
        {{"TRAVERSAL", std::to_string(uint32_t(settings_.traversal))}, {"PACKET", std::to_string(settings_.packet)}},
        sizeof(VisibilityPush));
    if (views_.size() > 1) c.defines.push_back({"VIEWS", std::to_string(views_.size())});
    if (layers_ > 1) c.defines.push_back({"LAYERS", std::to_string(layers_)});
    // Every view's map has the light's type: its defines fix it (ShadowMap::update throws
    // on a change), and one set serves them all.
    for (const auto& view : views_) {
        const std::vector<gpu::ShaderDefine> defines = view->shadowMap.shaderDefines();
        if (view == views_.front()) std::ranges::copy(defines, std::back_inserter(c.defines));
    }
    visibility_ = gpu::Pipeline(context_, setup.shaders, c);
    if (settings_.packet > 1)
        packets_.emplace(plugin::createComputePipeline(setup, "packets", "packets.comp", c.defines, c.pushConstantBytes));
    c.defines.push_back({"DEBUG_IMAGES", "1"});
    debugViews_.emplace(setup,
                        plugin::computePipelineDesc(setup, "debug_views", c.shader, c.defines, c.pushConstantBytes));

    compareSampler_ = render::createShadowCompareSampler(context_);
    depthSampler_ = render::createShadowDepthSampler(context_);
    for (auto& view : views_) writeLight(*view);
}

// The light itself, or its split_ x split_ sub-lights in row order.
std::vector<SubLight> BackprojectionShadow::subLights(const scene::Light& light) const
{
    const LightData whole = lightShape(light, settings_.lightSizeOverride);
    if (split_ == 1) return {SubLight{light, whole}};
    std::vector<SubLight> subs;
    for (int j = 0; j < split_; ++j)
        for (int i = 0; i < split_; ++i) subs.push_back(subLight(light, whole, split_, i, j));
    return subs;
}

// The MSSM is an array of atlas-sized layers (mssm.glsl), so its sides fit wherever the
// shadow map's do (ShadowMap refuses an atlas past the largest image); what it must fit
// is the device's largest allocation.
void BackprojectionShadow::checkDevice() const
{
    const render::ShadowMap& map = firstMap();
    const VkDeviceSize bytes = mssmBytes(map.atlasWidth(), map.atlasHeight(), levels_ * layers_);
    const VkDeviceSize largest = context_.maxMemoryAllocationSize();
    if (bytes <= largest) return;
    // The atlas holds `faces` faces of faceTexels() (the resolution and its guard texels)
    // a side: the largest face that fits, less the same guard, is the largest resolution
    // (a lower resolution's cap has at most as many levels, and the guard never grows).
    const VkDeviceSize face = VkDeviceSize(map.faceTexels()) * map.faceTexels();
    const VkDeviceSize faces = std::max<VkDeviceSize>(1, VkDeviceSize(map.atlasWidth()) * map.atlasHeight() / face);
    const auto largestFace = VkDeviceSize(std::floor(std::sqrt(double(largest / mssmBytes(1, 1, levels_ * layers_) / faces))));
    const VkDeviceSize guards = map.faceTexels() - settings_.resolution;
    const VkDeviceSize fits = largestFace > guards ? largestFace - guards : 0;
    throw ConfigError(fmt::format("backprojection: resolution: {} texels per face with max_kernel {} texels need a "
                                  "multi-scale shadow map of {} levels{} ({} MiB), more than this device's largest "
                                  "allocation ({} MiB, maxMemoryAllocationSize); use a resolution of at most {}, or "
                                  "a lower max_kernel",
                                  settings_.resolution, settings_.maxKernel, levels_,
                                  layers_ > 1 ? fmt::format(" for each of {} layers", layers_) : "", bytes >> 20,
                                  largest >> 20, fits));
}

void BackprojectionShadow::writeLight(View& view)
{
    LightData d = view.sub.shape;
    const render::ShadowMapData& map = view.shadowMap.data();
    for (uint32_t f = 0; f < std::min(map.faceCount, render::kMaxShadowFaces); ++f) d.faces[f] = faceFrame(map.faces[f]);
    std::memcpy(view.lightBuffer.mapped(), &d, sizeof(d));
    // The kernels reach no further than the (sub-)light's extent allows on this map (plus
    // the kernel's margin cell and the dual grid's sample), nor past half the cap.
    view.shadowMap.setSoftShadowFootprint(reachSize(d, view.sub.light.type), 0.5f * float(settings_.maxKernel) + 2.0f);
}

void BackprojectionShadow::update(const scene::Light& light, const scene::Aabb& sceneBounds)
{
    std::vector<SubLight> subs = subLights(light);
    for (size_t k = 0; k < views_.size(); ++k) {
        View& view = *views_[k];
        view.sub = std::move(subs[k]);
        view.shadowMap.update(view.sub.light, sceneBounds);
        writeLight(view);
    }
}

void BackprojectionShadow::registerPasses(graph::RenderGraph& graph, const plugin::LightPassIo& io)
{
    // The views one after another, each its map, MSSM, packets and share of V: the graph
    // keeps that order (its declaration order where nothing else decides), so their
    // images' lifetimes do not overlap and it reuses one allocation for all (§5). View
    // k's pass adds its share to the sum of the views before it (view<k>.sum, a cleared
    // image for view 0) and writes the sum with it (view<k+1>.sum); the last writes V_l.
    if (views_.size() > 1) {
        const std::string start = io.local("view0.sum");
        graph.declareImage({start, width_, height_, plugin::kVisibilityFormat});
        plugin::ClearPass(graph, start).image(start, {}).dependsOn(io.lightState);
    }
    for (size_t k = 0; k < views_.size(); ++k) addViewPasses(graph, io, k);
}

// View k's passes (with one view, the technique's passes under their plain names).
void BackprojectionShadow::addViewPasses(graph::RenderGraph& graph, const plugin::LightPassIo& io, size_t k)
{
    const bool multiView = views_.size() > 1, last = k + 1 == views_.size();
    ViewNames names;
    names.prefix = multiView ? fmt::format("view{}.", k) : "";
    names.map = io.local(names.prefix + "shadow_map");
    names.mssm = io.local(names.prefix + "mssm");
    names.packets = packets_ ? io.local(names.prefix + "packets") : std::string();
    names.out = last ? io.visibility : io.local(fmt::format("view{}.sum", k + 1));
    const std::string before = multiView ? io.local(names.prefix + "sum") : std::string();
    render::ShadowMap& map = views_[k]->shadowMap;

    const render::ShadowDepthBias bias{settings_.depthBias, 0.0f, 0.0f};
    const uint32_t firstView = uint32_t(k * map.faceCount());
    map.addDepthPass(graph, names.map, bias, firstView);
    if (layers_ > 1) {
        names.peeled = io.local("layer1.shadow_map");
        map.addPeeledDepthPass(graph, names.peeled, names.map, bias, firstView);
    }
    // Every layer's MSSM, an array layer a level, the second's after the first's (mssm.glsl).
    graph::ImageDesc mssmImage{names.mssm, map.atlasWidth(), map.atlasHeight(), kMssmFormat};
    mssmImage.layers = uint32_t(levels_ * layers_);
    graph.declareImage(mssmImage);
    graph::PassBuilder mssm = graph.addPass(names.mssm, graph::QueueKind::Compute);
    mssm.read(names.map, graph::Usage::Sampled).write(names.mssm, graph::Usage::Storage).dependsOn(io.lightState);
    if (!names.peeled.empty()) mssm.read(names.peeled, graph::Usage::Sampled);
    mssm.execute([this, k, names](graph::PassContext& pass) { recordMssm(pass, *views_[k], names); });

    // Packets (Algorithm 1, steps 6 and 7): one invocation per packet leaves each pixel's
    // V, or -1 where the visibility pass walks the pixel alone (step 8).
    if (packets_) {
        graph.declareImage({names.packets, width_, height_, kPacketsFormat});
        graph::PassBuilder pass = graph.addPass(names.packets, graph::QueueKind::Compute);
        plugin::readGBuffer(pass, io.gbuffer);
        pass.read(names.map, graph::Usage::Sampled)
            .read(names.mssm, graph::Usage::Storage)
            .write(names.packets, graph::Usage::Storage)
            .dependsOn(io.lightState)
            .dependsOn(io.cameraState)
            .execute([this, io, k, names](graph::PassContext& p) { recordPackets(p, io, k, names); });
    }

    const auto bind = [this, k, names, before](const graph::PassContext& pass, gpu::DescriptorPush& descriptors) {
        if (!names.packets.empty()) descriptors.storageImage("packetsIn", pass.image(names.packets));
        if (!before.empty()) descriptors.storageImage("viewsIn", pass.image(before));
        bindVisibility(pass, descriptors, k, names, visibility_);
    };
    if (!last) graph.declareImage({names.out, width_, height_, plugin::kVisibilityFormat});
    graph::PassBuilder visibility =
        last ? plugin::addVisibilityPass(graph, io, visibility_, bind)
             : plugin::addVisibilityStepPass(graph, io, io.local(names.prefix + "visibility"), names.out, visibility_,
                                             bind);
    visibility.read(names.map, graph::Usage::Sampled)
        .read(names.mssm, graph::Usage::Storage)
        .dependsOn(io.lightState)
        .dependsOn(io.cameraState);
    if (!names.peeled.empty()) visibility.read(names.peeled, graph::Usage::Sampled);
    if (packets_) visibility.read(names.packets, graph::Usage::Storage);
    if (!before.empty()) visibility.read(before, graph::Usage::Storage);

    // The view's debug views, culled unless one of their images is requested.
    std::vector<std::string> debugNames;
    std::vector<plugin::DebugImage> debugImages;
    for (const plugin::DebugImage& image : kDebugImages) debugNames.push_back(names.prefix + std::string(image.name));
    for (size_t i = 0; i < debugNames.size(); ++i) debugImages.push_back({debugNames[i], kDebugImages[i].binding});
    const auto bindDebug = [this, k, names](const graph::PassContext& pass, gpu::DescriptorPush& descriptors,
                                            const gpu::Pipeline& pipeline) {
        if (!names.packets.empty()) descriptors.storageImage("packetsIn", pass.image(names.packets));
        bindVisibility(pass, descriptors, k, names, pipeline);
    };
    graph::PassBuilder debug =
        debugViews_->addOverGBuffer(graph, io, io.local(names.prefix + "debug_views"), debugImages, bindDebug);
    debug.read(names.map, graph::Usage::Sampled).read(names.mssm, graph::Usage::Storage);
    if (!names.peeled.empty()) debug.read(names.peeled, graph::Usage::Sampled);
    if (packets_) debug.read(names.packets, graph::Usage::Storage);
}

void BackprojectionShadow::recordMssm(const graph::PassContext& pass, const View& view, const ViewNames& names) const
{
    VkCommandBuffer cmd = pass.cmd();
    const glm::ivec2 size = atlasSize();
    // Layer j's MSSM in the array layers after layer j - 1's; level 0 of each from its own
    // depth map.
    for (int layer = 0; layer < layers_; ++layer) {
        const std::string& map = layer == 0 ? names.map : names.peeled;
        for (int level = 0; level < levels_; ++level) {
            const gpu::Pipeline& pipeline = level == 0 ? mssmLevel0_ : mssm_;
            if (level > 0) gpu::memoryBarrier(cmd, gpu::access::kComputeStorageWrite, gpu::access::kComputeStorageReadWrite);
            if (level <= 1) {
                pipeline.bind(cmd);
                gpu::DescriptorPush descriptors;
                if (level == 0)
                    descriptors.sampledImage("shadowDepth", pass.image(map), depthSampler_, pass.layout(map));
                descriptors.storageImage("mssmImage", pass.image(names.mssm)).push(context_, cmd, pipeline);
            }
            const MssmPush push{size, int32_t(view.shadowMap.faceTexels()), level, layer * levels_};
            pipeline.pushConstants(cmd, &push, sizeof(push));
            pipeline.dispatchOver(cmd, uint32_t(size.x), uint32_t(size.y));
        }
    }
}

void BackprojectionShadow::bindVisibility(const graph::PassContext& pass, gpu::DescriptorPush& descriptors,
                                          size_t view, const ViewNames& names, const gpu::Pipeline& pipeline) const
{
    const View& v = *views_[view];
    descriptors.sampledImage("shadowCompare", pass.image(names.map), compareSampler_, pass.layout(names.map))
        .storageBuffer("shadowMapBuffer", v.shadowMap.buffer())
        .sampledImage("shadowDepth", pass.image(names.map), depthSampler_, pass.layout(names.map))
        .storageImage("mssmImage", pass.image(names.mssm))
        .storageBuffer("BackprojectionLight", v.lightBuffer);
    if (!names.peeled.empty())
        descriptors.sampledImage("peeledDepth", pass.image(names.peeled), depthSampler_, pass.layout(names.peeled));
    const VisibilityPush push{levels_,
                              settings_.maxKernel,
                              settings_.edgeCost,
                              settings_.visibilityCost,
                              settings_.divergenceThreshold,
                              loopBudget_,
                              settings_.coherence == Coherence::Model ? 1 : 0};
    pipeline.pushConstants(pass.cmd(), &push, sizeof(push));
}

void BackprojectionShadow::recordPackets(const graph::PassContext& pass, const plugin::LightPassIo& io, size_t view,
                                         const ViewNames& names) const
{
    const VkCommandBuffer cmd = pass.cmd();
    packets_->bind(cmd);
    gpu::DescriptorPush descriptors;
    plugin::bindGBuffer(pass, io.gbuffer, descriptors);
    descriptors.storageImage("packetsOut", pass.image(names.packets));
    bindVisibility(pass, descriptors, view, names, *packets_);
    descriptors.push(context_, cmd, *packets_);
    const auto packetsOver = [this](uint32_t pixels) {
        return (pixels + uint32_t(settings_.packet) - 1) / uint32_t(settings_.packet);
    };
    packets_->dispatchOver(cmd, packetsOver(width_), packetsOver(height_));
}

} // namespace
} // namespace penumbra::backprojection

PENUMBRA_DEFINE_PLUGIN("backprojection", "1.0.0",
                       "soft shadows by back-projection: marching-squares contours over a multi-scale shadow map, "
                       "radial integration of the hidden light area, hierarchical traversal, pixel packets, multi-view "
                       "sub-lights (Guennebaud et al. 2007, Yang et al. 2009)",
                       penumbra::backprojection::kParams, penumbra::backprojection::BackprojectionShadow)
