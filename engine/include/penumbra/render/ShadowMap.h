#pragma once
// The casters' depth as one light sees it, for every technique that needs a shadow map
// (hard, pcss, the VSM family, a rasterised reference): the light's views, the data
// shaders read about them, and the depth pass with its pipelines.
//
//   spot                 one perspective map over the outer cone
//   directional          one orthographic map fitted around the scene
//   point, rect, disk    six cube faces around the light's centre, +X -X +Y -Y +Z -Z,
//                        packed 3 x 2 in one atlas (face f at cell (f % 3, f / 3)): 90°
//                        each, plus the technique's guard band beyond every edge
//                        (guardTexels; docs/plugins.md, "Cube edges")
//
// Frusta come from render::shadowFrusta (Projection.h). Every map is reversed-Z
// D32_SFLOAT: 1 at the near plane, 0 where nothing was drawn. Alpha-masked casters cut
// their holes (a fragment shader tests alpha); both sides of every triangle cast.
//
// Shaders read the maps through shaders/common/shadow_map.glsl (projection, face choice,
// atlas addressing, distances and normalised depth along the light) and
// shaders/common/shadow_receiver.glsl (the receiver as the map sees it, with normal
// offset or receiver plane bias). docs/plugins.md, "Shadow maps", walks through a use.
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/gpu/Resources.h"
#include "penumbra/graph/RenderGraph.h"
#include "penumbra/render/Casters.h"
#include "penumbra/render/Projection.h"
#include "penumbra/scene/Scene.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra::gpu {
class Context;
class ShaderCompiler;
} // namespace penumbra::gpu

namespace penumbra::graph {
class PassContext;
}

namespace penumbra::render {

inline constexpr uint32_t kMaxShadowFaces = 6;
inline constexpr VkFormat kShadowDepthFormat = VK_FORMAT_D32_SFLOAT;
// Points in shaders/common/poisson_disk.glsl: a filter takes the first N.
inline constexpr int kPoissonDiskPoints = 64;

// 1 for spot and directional lights, 6 (a cube atlas) for point, rect and disk lights.
uint32_t shadowFaceCount(scene::LightType type);

// One face (std430; shaders/common/shadow_map.glsl ShadowFace).
struct ShadowFaceData {
    glm::mat4 viewProj{1.0f};  // world -> clip, reversed-Z
    // x: world size of one texel per unit of clip w at the receiver (perspective: w is
    // the distance along the face's axis, so texels grow with distance; orthographic:
    // w = 1). The larger of the two axes'. yzw unused.
    glm::vec4 texel{0.0f};
    // x: near, y: far: distances along the face's axis (world) between which every
    // caster and receiver of the scene lies; z: 1 for an orthographic face, 0 for a
    // perspective one; w unused. shadowDistance() / shadowLinearDepth() use them.
    glm::vec4 depthRange{0.0f};
};

// What shaders know about the map (std430; shadow_map.glsl ShadowMapBuffer).
struct ShadowMapData {
    glm::vec4 light{0.0f};     // xyz position (w = 1), or unit direction towards the light (w = 0)
    uint32_t faceCount = 1;    // 1, or 6 cube faces in a 3 x 2 atlas
    float faceTexels = 0.0f;   // texels per face side
    uint32_t lightType = 0;    // scene::LightType
    uint32_t pad0 = 0;
    // The light's extent, for the part of it above a receiver's horizon
    // (shadowLightAboveHorizon in shadow_map.glsl). xyz: the unit emitting normal (rect,
    // disk), w: the rect's half width, the disk's or sphere's radius, the sine of a
    // directional light's angular radius; 0 for a light without extent.
    glm::vec4 lightAxis{0.0f};
    glm::vec4 lightTangent{0.0f};  // rect: xyz the unit width axis, w the half height
    ShadowFaceData faces[kMaxShadowFaces];
};
static_assert(sizeof(ShadowFaceData) == 96 && sizeof(ShadowMapData) == 64 + 6 * 96, "std430 layout of shadow_map.glsl");

// The light's size as the PCSS framework's kernels use it (shaders/common/
// penumbra_estimate.glsl): for lights at a position w_light in world units (a rect's
// side of equal area, a disk's diameter; spot and point lights have none: 0, a hard
// shadow), for a directional light 2 tan(θ/2) of its angular diameter θ (clamped below
// 179°, so the tangent stays finite). `overrideSize` >= 0 replaces the light's own size
// (world units; directional: degrees).
float softShadowLightSize(const scene::Light& light, float overrideSize);

// The widest half-width, in texels of a face, that the PCSS framework's kernels
// (penumbra_estimate.glsl: the blocker search and the penumbra filter) reach on the map
// `data` describes for a light of `lightSize` (softShadowLightSize), before a technique's
// own limit. Perspective faces: both are at most lightSize / near as an angle (the search
// (lightSize / near) (d_r - near) / d_r, the filter (gap / d_r) lightSize / max(d_b,
// near)); orthographic: (far - near) lightSize in world units. 0 for a light of size 0 or
// a degenerate face (texel 0 or NaN); +inf where the bound overflows (a technique's limit
// then holds).
float softShadowKernelReach(const ShadowMapData& data, float lightSize);

// The guard band (ShadowMap's guardTexels) a filter needs whose taps reach `reachTexels`
// (half-width, texels of a `resolution`-texel face) from the receiver's texel: that
// plus one texel for the taps' rounding to texel centres, at most a quarter of the face
// plus that texel (then (1.5)² the texels; taps beyond the band read its edge). 0 for
// no reach (or NaN).
uint32_t kernelGuardTexels(float reachTexels, uint32_t resolution);

// Samplers that read a shadow map by its conventions, clamped to the edge (lookups stay
// in their face: the shaders clamp them). The comparison sampler's compareOp is
// GREATER_OR_EQUAL (reversed-Z: a receiver is lit where its depth is at least the stored
// caster depth); NEAREST compares one texel, LINEAR is the hardware's 2 x 2 bilinear
// compare. The depth sampler reads the stored depths, one texel per tap.
gpu::Sampler createShadowCompareSampler(gpu::Context& context, VkFilter filter = VK_FILTER_NEAREST);
gpu::Sampler createShadowDepthSampler(gpu::Context& context);

// Receiver-side bias of shadow_receiver.glsl (its SHADOW_RECEIVER_BIAS define).
enum class ReceiverBias : uint32_t { None = 0, NormalOffset = 1, Plane = 2 };

// Where recordDepthMaps draws one map of the light's shape: its faces' frusta (as
// shadowFrusta gives them, at most faceCount()), the top-left texel of its atlas in the
// depth image, and the CasterView::view of its first face (the others follow).
struct ShadowMapPlacement {
    std::span<const LightFrustum> frusta;
    VkOffset2D origin{0, 0};
    uint32_t firstView = 0;
};

// One face of a map as a caster pass draws it (ShadowMap::faceDraws): the view the casters
// are culled for, the face's cell of the atlas as the viewport, and the scissor (the
// cell, or within it the texels this frame's receivers can read).
struct ShadowFaceDraw {
    CasterView view;
    VkViewport viewport{};
    VkRect2D scissor{};
};
struct ShadowFaceDraws {
    std::vector<ShadowFaceDraw> faces;  // the faces some receiver reads
    VkRect2D area{};                    // the union of their scissors, or the whole image
};

// What a depth pass clears (ShadowMap::recordDepthMaps): the whole image (or, when only
// the lookups read it, the union of the texels they read), or only each face it draws,
// the rest of the image keeping what it holds (a persistent atlas of tiles drawn a few at
// a time: the adaptive shadow map's).
enum class MapClear { Image, EachFace };

// What a shadow map needs from the technique that owns it. A plugin::TechniqueSetup
// converts to it, so a technique passes its own setup; the map takes no more than this
// because render sits below plugin (plugin/Technique.h includes this header, not the
// other way round). References stay valid for the map's lifetime.
struct ShadowMapSetup {
    gpu::Context& context;
    const gpu::ShaderCompiler& shaders;  // the technique's: it finds the engine's shaders/ too
    const Casters& casters;
    const scene::Light& light;  // the first frame's state
    scene::Aabb sceneBounds;
    uint32_t lightIndex = 0;
};

// One light's shadow map: its frusta, a host-visible buffer of ShadowMapData for the
// shaders, and the depth pass. Owned by the technique (one per light).
class ShadowMap {
public:
    // For the technique created with `setup`; `technique` ("hard") names its GPU objects
    // ("light0.hard.shadow_map") and prefixes errors. `resolution`: texels across a face
    // (a cube face's 90°). `guardTexels` (cube maps; ignored for one face): texels each
    // cube face holds beyond each of its 90° edges, at the same density, so that a
    // filter whose taps reach that far past a cube edge reads them in the receiver's own
    // face (kernelGuardTexels); they cost (1 + 2 guard / resolution)² in texels drawn
    // and stored. Throws penumbra::ConfigError when the atlas exceeds the device's
    // largest image (naming `resolution`), penumbra::Error when a shader does not
    // compile.
    ShadowMap(const ShadowMapSetup& setup, uint32_t resolution, std::string_view technique, uint32_t guardTexels = 0);
    ShadowMap(const ShadowMap&) = delete;
    ShadowMap& operator=(const ShadowMap&) = delete;

    // Refits the frusta to the light and the scene bounds and rewrites buffer(). Call it
    // from Technique::update; throws when the light changed to a type with another face
    // count (the map was sized for the first), or changed type at all after
    // shaderDefines() (its shaders were compiled for the first).
    void update(const scene::Light& light, const scene::Aabb& sceneBounds);

    // Declares the transient depth image `image` (atlasWidth() x atlasHeight(),
    // kShadowDepthFormat) and the graphics pass named `image` that clears it and draws
    // every face's casters with `bias`. Readers declare it as Usage::Sampled. `firstView`:
    // the CasterView::view of its first face (the others follow), so that a technique
    // with several maps of one light (sub-lights) gives each its own culled views. The
    // pass depends on lightState(the light) alone: the engine keeps the map while the
    // light and its casters are unchanged (as it does the peeled layers).
    void addDepthPass(graph::RenderGraph& graph, const std::string& image, ShadowDepthBias bias,
                      uint32_t firstView = 0) const;
    // The same pass for the casters that block all the light that reaches them: opaque
    // ones, and alpha-masked ones where they are not cut. Translucent (BLEND) casters are
    // left out (addDepthPass draws them as opaque): the nearest surface no light passes,
    // behind which a deep shadow map need not store anything.
    void addOpaqueDepthPass(graph::RenderGraph& graph, const std::string& image, ShadowDepthBias bias,
                            uint32_t firstView = 0) const;

    // Depth peeling (Everitt 2001; the multi-layer shadow maps of Bavoil et al. 2008 and
    // Schwarz and Stamminger 2007): declares the transient depth image `image`, like
    // addDepthPass's, and the graphics pass named `image` that draws into it, per texel,
    // the nearest caster surface strictly behind the one `nearerLayer` stores there
    // (an image of this map's addDepthPass, or of this function for a third layer, drawn
    // with the same `bias` and `firstView`). A texel with nothing behind its nearer
    // layer stays cleared (0, the far plane). A closed caster's second layer is its own
    // far side; a single-sided surface (a plate) has none. The peeling pipelines are
    // created on the first call.
    void addPeeledDepthPass(graph::RenderGraph& graph, const std::string& image, const std::string& nearerLayer,
                            ShadowDepthBias bias, uint32_t firstView = 0);

    // Records, in a graphics pass that writes `image` as Usage::DepthAttachment, the clear
    // of the image (of the texels the receivers read: setReadByLookupsOnly) and the casters of every map of `maps` into its atlas at its
    // origin, with `bias`: the depth pass of addDepthPass for one map, and for a technique
    // that packs the maps of several views of the light's shape into one image with the
    // pipelines created once (the reference's rasterised light samples). The cells of the
    // faces each map draws (face f at (f % 3, f / 3) faceTexels() from its origin) must
    // lie inside the image: a map of one frustum takes one cell (an adaptive shadow map's
    // tile of a cube face).
    // MapClear::EachFace clears and draws only the maps' faces and keeps every other texel
    // (no maps: records nothing).
    void recordDepthMaps(const graph::PassContext& pass, const std::string& image, ShadowDepthBias bias,
                         std::span<const ShadowMapPlacement> maps, MapClear clear = MapClear::Image) const;

    // The faces that a caster pass writing `image` (Usage::DepthAttachment or Storage, at
    // least as large as every map's atlas at its origin) draws for `maps` with `bias`,
    // with this map's footprint, compare radius and read area (setReadByLookupsOnly), and
    // the render area: what recordDepthMaps draws, for a technique whose caster pass is
    // not a depth map (a deep shadow map's fragment lists). Throws when a map does not fit.
    ShadowFaceDraws faceDraws(const graph::PassContext& pass, const std::string& image, ShadowDepthBias bias,
                              std::span<const ShadowMapPlacement> maps) const;

    // How far, in texels, the technique's lookups for one receiver point reach beyond
    // the texel it projects to (CasterView::footprintTexels; kWholeView for mip chains):
    // the visibility service keeps the casters within that reach of a visible receiver.
    // 0 (a single nearest compare) until set.
    void setFootprint(float texels) { footprint_ = texels; }
    float footprint() const { return footprint_; }
    // For the PCSS framework's kernels clamped to `maxKernelTexels` (half-widths): sets the
    // footprint to the least of that and softShadowKernelReach(data(), lightSize), plus one
    // texel for the taps' rounding, and returns it. Call it after every update(): the
    // reach follows the frusta, so a light whose kernels never grow wide keeps caster
    // culling tight however generous the technique's limit.
    float setSoftShadowFootprint(float lightSize, float maxKernelTexels);

    // Declares that every lookup compares the map with the receiver point's own depth,
    // reading the texels within `tapRadius` (a square) of the one the point projects to
    // (CasterView::compareTapRadius); -1 (the default): the lookups do something else.
    // Receiver-mask culling then draws only the casters that lie in front of a visible
    // receiver point after the depth pass's bias.
    void setOwnDepthCompare(int32_t tapRadius) { compareTapRadius_ = tapRadius; }

    // Declares that only the receivers' lookups read the map (compares within the
    // footprint, in a visibility pass), no pass over all of it (moments, blurs,
    // summed-area tables, mip chains). The depth pass then clears and draws only the
    // texels that this frame's receivers can read (Casters::readArea: with receiver-mask
    // culling, the bounds of the view's dilated receiver mask), and the rest of the map
    // is undefined; a map that is a marked output (a debug image) is drawn whole. On a
    // CPU rasteriser the clear and store of a whole 4096² map cost more than the culled
    // casters drawn into it (docs/culling.md). false (the default): the whole map.
    void setReadByLookupsOnly(bool only) { readByLookupsOnly_ = only; }

    uint32_t faceCount() const { return faceCount_; }
    // The map's layout for its shaders: SHADOW_FACE_COUNT, SHADOW_FACE_TEXELS and
    // SHADOW_LIGHT_TYPE, so that common/shadow_map.glsl's branches on them fold away at
    // compile time and no lookup loads them. Append them to the defines of every pipeline
    // that reads this map's buffer(). From the first call on, the light's type is fixed
    // too: update() throws when it changes (without the call, a map takes any type of its
    // face count, as the reference's light samples do).
    std::vector<gpu::ShaderDefine> shaderDefines();
    uint32_t resolution() const { return resolution_; }
    // Texels beyond each edge of a cube face (0 for one face), and per face side in all.
    uint32_t guardTexels() const { return guard_; }
    uint32_t faceTexels() const { return resolution_ + 2 * guard_; }
    uint32_t atlasWidth() const { return faceTexels() * (faceCount_ == kMaxShadowFaces ? 3u : 1u); }
    uint32_t atlasHeight() const { return faceTexels() * (faceCount_ == kMaxShadowFaces ? 2u : 1u); }
    // ShadowMapData, as shaders/common/shadow_map.glsl binds it (a storage buffer).
    const gpu::Buffer& buffer() const { return buffer_; }
    const ShadowMapData& data() const { return data_; }
    const std::vector<LightFrustum>& frusta() const { return frusta_; }

private:
    gpu::Context& context_;
    const Casters& casters_;
    const uint32_t lightIndex_;
    const std::string name_;  // "light0.hard"
    const uint32_t resolution_;
    const uint32_t faceCount_;
    const uint32_t guard_;  // 0 for one face
    const scene::LightType lightType_;  // as created
    bool typeCompiledIn_ = false;          // shaderDefines() was asked for
    // addDepthPass and addOpaqueDepthPass: the casters without alpha mask that `unmasked`
    // selects (Solid, Opaque), and the alpha-masked ones.
    void addMapPass(graph::RenderGraph& graph, const std::string& image, ShadowDepthBias bias, uint32_t firstView,
                    DrawFilter unmasked) const;
    // Draws `maps` into `image`; with `nearerLayer`, the peeling pipelines draw only what
    // lies behind it; `unmasked` selects the casters without alpha mask (Solid, Opaque).
    void recordLayer(const graph::PassContext& pass, const std::string& image, ShadowDepthBias bias,
                     std::span<const ShadowMapPlacement> maps, const std::string* nearerLayer,
                     DrawFilter unmasked = DrawFilter::Solid, MapClear clear = MapClear::Image) const;

    const gpu::ShaderCompiler& shaders_;
    gpu::GraphicsPipelineDesc depthDesc_;  // the solid casters' pipeline, which the others extend
    gpu::Pipeline depth_;        // solid casters: no fragment shader
    gpu::Pipeline depthMasked_;  // alpha-masked casters: a fragment shader cuts the holes
    gpu::Pipeline peel_;         // addPeeledDepthPass: solid casters behind the nearer layer
    gpu::Pipeline peelMasked_;   // and alpha-masked ones
    gpu::Sampler peelSampler_;   // reads the nearer layer's depths, one texel each
    gpu::Buffer buffer_;         // data_ for the shaders, host-visible
    ShadowMapData data_;
    std::vector<LightFrustum> frusta_;
    float footprint_ = 0.0f;
    int32_t compareTapRadius_ = -1;
    bool readByLookupsOnly_ = false;
};

} // namespace penumbra::render
