#include "penumbra/render/ShadowMap.h"

#include "penumbra/core/Error.h"
#include "penumbra/gpu/Context.h"
#include "penumbra/graph/PassContext.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <climits>
#include <cstring>
#include <optional>
#include <vector>

namespace penumbra::render {

uint32_t shadowFaceCount(scene::LightType type)
{
    return type == scene::LightType::Spot || type == scene::LightType::Directional ? 1u : kMaxShadowFaces;
}

namespace {

// The most a rect or disk light's own extent along a face axis, as a receiver sees it
// (common/penumbra_estimate.glsl shadowLightExtent), can be over softShadowLightSize:
// (w + h) / sqrt(w h) for the rect's sides, times sqrt(1 + m^2) for a receiver at m =
// tan of its angle off the face's axis, at most 1.5 on a cube face with its guard
// (kernelGuardTexels: a quarter of the face each side). Capped: a rect a million times
// longer than wide reaches no further than the clamps in texels anyway.
float lightShapeBound(const ShadowMapData& data)
{
    constexpr float kMostObliqueness = 1.8028f;  // sqrt(1 + 1.5^2)
    constexpr float kMostRatio = 1000.0f;
    if (data.lightType == uint32_t(scene::LightType::Disk)) return kMostObliqueness;
    if (data.lightType != uint32_t(scene::LightType::Rect)) return 1.0f;
    const float w = 2.0f * data.lightAxis.w, h = 2.0f * data.lightTangent.w;
    const float area = std::sqrt(std::max(w * h, 0.0f));
    if (!(area > 0.0f)) return 1.0f;
    return std::min((w + h) / area, kMostRatio) * kMostObliqueness;
}

// World size of one texel per unit of clip w (ShadowFaceData::texel). A texel spans
// 2 / R of NDC and NDC x = P00 · x_view / w (orthographic: w = 1), so at clip w it spans
// 2 w / (P00 · R) of the world; the larger of the x and y sizes (an orthographic box
// need not be square).
float worldTexelPerW(const glm::mat4& proj, uint32_t resolution)
{
    const float scale = std::min(std::abs(proj[0][0]), std::abs(proj[1][1]));
    return scale > 0.0f ? 2.0f / (scale * float(resolution)) : 0.0f;
}

bool isOrthographic(const glm::mat4& proj) { return proj[3][3] == 1.0f; }

// Near and far distance along the face's axis between which the scene lies.
// Orthographic (Projection.cpp directionalFrustum): depth = (far - d) / (far - near), so
// P22 = 1 / (far - near) and P32 = far / (far - near). Perspective: the near plane the
// frustum was built with, and the farthest corner of the scene box along the view axis.
// far > near always: the shaders divide by far - near.
glm::vec2 depthRange(const LightFrustum& f, const scene::Aabb& bounds)
{
    if (isOrthographic(f.proj)) {
        const float p22 = f.proj[2][2], p32 = f.proj[3][2];
        const glm::vec2 range(p32 / p22 - 1.0f / p22, p32 / p22);
        // A degenerate box (a scene of one point) gives no usable range.
        if (std::isfinite(range.x) && std::isfinite(range.y) && range.y > range.x) return range;
        return {f.nearWorld, f.nearWorld + std::max(std::abs(f.nearWorld), 1.0f)};
    }
    float far = 0.0f;
    if (!bounds.empty()) {
        // View space looks down -z: the distance along the axis is -z_view.
        for (int c = 0; c < 8; ++c) far = std::max(far, -(f.view * glm::vec4(bounds.corner(c), 1.0f)).z);
    }
    // A scene entirely behind the face (or none): any range will do, nothing projects.
    return {f.nearWorld, std::max(far, 2.0f * f.nearWorld)};
}

} // namespace

uint32_t kernelGuardTexels(float reachTexels, uint32_t resolution)
{
    if (!(reachTexels > 0.0f)) return 0;
    const float most = std::ceil(0.25f * float(resolution));
    return uint32_t(std::ceil(std::min(reachTexels, most))) + 1;
}

ShadowMap::ShadowMap(const ShadowMapSetup& setup, uint32_t resolution, std::string_view technique, uint32_t guardTexels)
    : context_(setup.context),
      casters_(setup.casters),
      lightIndex_(setup.lightIndex),
      name_(fmt::format("light{}.{}", setup.lightIndex, technique)),
      resolution_(resolution),
      faceCount_(shadowFaceCount(setup.light.type)),
      guard_(faceCount_ == kMaxShadowFaces ? std::min(guardTexels, resolution) : 0u),
      lightType_(setup.light.type),
      shaders_(setup.shaders),
      buffer_(setup.context, sizeof(ShadowMapData), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, true, name_ + ".shadow_faces")
{
    if (resolution_ == 0) throw ConfigError(fmt::format("{}: resolution: must be at least 1 texel, got 0", technique));
    const uint32_t maxDimension = context_.properties().limits.maxImageDimension2D;
    if (atlasWidth() > maxDimension) {
        const bool cube = faceCount_ == kMaxShadowFaces;
        throw ConfigError(fmt::format("{}: resolution: {} texels per face {}{}needs a {}-texel wide map, more than "
                                      "this device's largest image ({}); use at most {}",
                                      technique, resolution_, cube ? "in a 3 x 2 cube atlas " : "",
                                      guard_ > 0 ? fmt::format("with {} guard texels beyond each edge ", guard_) : "",
                                      atlasWidth(), maxDimension,
                                      uint64_t(maxDimension / (cube ? 3u : 1u)) * resolution_ / faceTexels()));
    }

    gpu::GraphicsPipelineDesc d;
    d.name = name_ + ".shadow_map";
    d.vertexShader = "engine/shadow_depth.vert";
    d.pushConstantBytes = sizeof(glm::mat4);
    d.vertexLayout = casters_.positionLayout();
    d.depthFormat = kShadowDepthFormat;
    d.depthCompare = VK_COMPARE_OP_GREATER_OR_EQUAL;  // reversed-Z: nearer is larger
    d.depthBias = true;
    // Both faces cast: a receiver's own back faces would otherwise let light leak
    // through single-sided or open geometry.
    d.cullMode = VK_CULL_MODE_NONE;
    depthDesc_ = d;
    depth_ = gpu::Pipeline(context_, setup.shaders, d);
    if (casters_.hasAlphaMasked()) {
        d.name += ".masked";
        d.fragmentShader = "engine/shadow_depth.frag";
        d.defines = {{"ALPHA_MASK", "1"}};
        d.vertexLayout = casters_.positionUvLayout();
        depthMasked_ = gpu::Pipeline(context_, setup.shaders, d);
    }
    update(setup.light, setup.sceneBounds);
}

std::vector<gpu::ShaderDefine> ShadowMap::shaderDefines()
{
    typeCompiledIn_ = true;
    return {{"SHADOW_FACE_COUNT", std::to_string(faceCount_)},
            {"SHADOW_FACE_TEXELS", std::to_string(faceTexels())},
            {"SHADOW_LIGHT_TYPE", std::to_string(uint32_t(lightType_))}};
}

void ShadowMap::update(const scene::Light& light, const scene::Aabb& sceneBounds)
{
    if (shadowFaceCount(light.type) != faceCount_) {
        throw Error(fmt::format("{}: light {} changed type to {}; the shadow map was created for {} face(s)", name_,
                                lightIndex_, scene::lightTypeName(light.type), faceCount_));
    }
    if (typeCompiledIn_ && light.type != lightType_) {
        throw Error(fmt::format("{}: light {} changed type from {} to {}; the technique's shaders were compiled for "
                                "the first",
                                name_, lightIndex_, scene::lightTypeName(lightType_), scene::lightTypeName(light.type)));
    }
    // Focused on what the camera sees when the config asks for it (visibility/Visibility.h).
    // A cube face's guard band widens it beyond 90° at the same texel density.
    frusta_ = shadowFrusta(light, sceneBounds, casters_.focus(), float(faceTexels()) / float(resolution_));
    data_ = {};
    data_.faceCount = faceCount_;
    data_.faceTexels = float(faceTexels());
    for (size_t i = 0; i < frusta_.size(); ++i) {
        const LightFrustum& f = frusta_[i];
        const glm::vec2 range = depthRange(f, sceneBounds);
        data_.faces[i] = {f.viewProj, glm::vec4(worldTexelPerW(f.proj, faceTexels()), 0.0f, 0.0f, 0.0f),
                          glm::vec4(range.x, range.y, isOrthographic(f.proj) ? 1.0f : 0.0f, 0.0f)};
    }
    if (light.type == scene::LightType::Directional) {
        const float length = glm::length(light.direction);
        data_.light = glm::vec4(length > 0.0f ? -light.direction / length : glm::vec3(0.0f, 1.0f, 0.0f), 0.0f);
    } else {
        data_.light = glm::vec4(light.position, 1.0f);
    }
    data_.lightType = uint32_t(light.type);
    data_.lightAxis = data_.lightTangent = glm::vec4(0.0f);
    switch (light.type) {
    case scene::LightType::Rect:
        data_.lightAxis = glm::vec4(light.direction, 0.5f * light.sizeWorld.x);
        data_.lightTangent = glm::vec4(light.tangent, 0.5f * light.sizeWorld.y);
        break;
    case scene::LightType::Disk:
    case scene::LightType::Point:
        data_.lightAxis = glm::vec4(light.direction, light.radiusWorld);
        break;
    case scene::LightType::Directional:
        data_.lightAxis = glm::vec4(0.0f, 0.0f, 0.0f,
                                    std::sin(glm::radians(std::clamp(0.5f * light.angularDiameterDeg, 0.0f, 90.0f))));
        break;
    case scene::LightType::Spot:
        break;
    }
    std::memcpy(buffer_.mapped(), &data_, sizeof(data_));
}

void ShadowMap::addDepthPass(graph::RenderGraph& graph, const std::string& image, ShadowDepthBias bias,
                             uint32_t firstView) const
{
    addMapPass(graph, image, bias, firstView, DrawFilter::Solid);
}

void ShadowMap::addOpaqueDepthPass(graph::RenderGraph& graph, const std::string& image, ShadowDepthBias bias,
                                   uint32_t firstView) const
{
    addMapPass(graph, image, bias, firstView, DrawFilter::Opaque);
}

void ShadowMap::addMapPass(graph::RenderGraph& graph, const std::string& image, ShadowDepthBias bias,
                           uint32_t firstView, DrawFilter unmasked) const
{
    // Transient: written and read within the frame, so the graph may alias its memory
    // with other lights' maps.
    graph.declareImage({image, atlasWidth(), atlasHeight(), kShadowDepthFormat});
    graph.addPass(image, graph::QueueKind::Graphics)
        .write(image, graph::Usage::DepthAttachment)
        .dependsOn(lightState(lightIndex_))
        .execute([this, image, bias, firstView, unmasked](graph::PassContext& pass) {
            const ShadowMapPlacement own{frusta_, {0, 0}, firstView};
            recordLayer(pass, image, bias, {&own, 1}, nullptr, unmasked);
        });
}

void ShadowMap::addPeeledDepthPass(graph::RenderGraph& graph, const std::string& image,
                                   const std::string& nearerLayer, ShadowDepthBias bias, uint32_t firstView)
{
    if (!peel_.handle()) {
        gpu::GraphicsPipelineDesc d = depthDesc_;
        d.name += ".peel";
        d.fragmentShader = "engine/shadow_depth.frag";
        d.defines = {{"PEEL", "1"}};
        peel_ = gpu::Pipeline(context_, shaders_, d);
        if (casters_.hasAlphaMasked()) {
            d.name += ".masked";
            d.defines.push_back({"ALPHA_MASK", "1"});
            d.vertexLayout = casters_.positionUvLayout();
            peelMasked_ = gpu::Pipeline(context_, shaders_, d);
        }
        peelSampler_ = createShadowDepthSampler(context_);
    }
    graph.declareImage({image, atlasWidth(), atlasHeight(), kShadowDepthFormat});
    graph.addPass(image, graph::QueueKind::Graphics)
        .read(nearerLayer, graph::Usage::Sampled)
        .write(image, graph::Usage::DepthAttachment)
        .dependsOn(lightState(lightIndex_))
        .execute([this, image, nearerLayer, bias, firstView](graph::PassContext& pass) {
            const ShadowMapPlacement own{frusta_, {0, 0}, firstView};
            recordLayer(pass, image, bias, {&own, 1}, &nearerLayer);
        });
}

void ShadowMap::recordDepthMaps(const graph::PassContext& pass, const std::string& image, ShadowDepthBias bias,
                                std::span<const ShadowMapPlacement> maps, MapClear clear) const
{
    recordLayer(pass, image, bias, maps, nullptr, DrawFilter::Solid, clear);
}

namespace {

// The smallest rectangle holding every face's scissor (`faces` not empty).
VkRect2D scissorUnion(const std::vector<ShadowFaceDraw>& faces)
{
    int32_t x0 = INT32_MAX, y0 = INT32_MAX, x1 = 0, y1 = 0;
    for (const ShadowFaceDraw& face : faces) {
        x0 = std::min(x0, face.scissor.offset.x);
        y0 = std::min(y0, face.scissor.offset.y);
        x1 = std::max(x1, face.scissor.offset.x + int32_t(face.scissor.extent.width));
        y1 = std::max(y1, face.scissor.offset.y + int32_t(face.scissor.extent.height));
    }
    return {{x0, y0}, {uint32_t(x1 - x0), uint32_t(y1 - y0)}};
}

} // namespace

ShadowFaceDraws ShadowMap::faceDraws(const graph::PassContext& pass, const std::string& image, ShadowDepthBias bias,
                                     std::span<const ShadowMapPlacement> maps) const
{
    const gpu::Image& target = pass.image(image);
    const uint32_t size = faceTexels();
    for (const ShadowMapPlacement& map : maps) {
        if (map.frusta.size() > faceCount_)
            throw Error(fmt::format("{}: a map of {} faces does not fit this shadow map's {} face(s)", name_,
                                    map.frusta.size(), faceCount_));
        // The cells of the faces it draws (a map of fewer faces than the atlas holds needs
        // only theirs: an adaptive shadow map's tile, one face of a cube).
        const uint64_t width = uint64_t(std::min<size_t>(map.frusta.size(), 3)) * size;
        const uint64_t height = uint64_t(map.frusta.size() > 3 ? 2 : 1) * size;
        if (map.origin.x < 0 || map.origin.y < 0 || uint64_t(map.origin.x) + width > target.desc().width ||
            uint64_t(map.origin.y) + height > target.desc().height)
            throw Error(fmt::format("{}: a map at ({}, {}) does not fit in '{}' ({} x {})", name_, map.origin.x,
                                    map.origin.y, image, target.desc().width, target.desc().height));
    }
    // Each face draws into its own cell of the map's atlas (the scissor keeps it there),
    // and, when only the receivers' lookups read the map, into the texels they can read;
    // the render area, which bounds the clear, is then the union of the faces' scissors.
    // Otherwise it is the whole image.
    ShadowFaceDraws draws;
    const bool readWhole = !readByLookupsOnly_ || pass.isOutput(image);
    for (const ShadowMapPlacement& map : maps)
        for (uint32_t face = 0; face < map.frusta.size(); ++face) {
            const int32_t x = map.origin.x + int32_t((face % 3) * size), y = map.origin.y + int32_t((face / 3) * size);
            ShadowFaceDraw draw{{map.frusta[face].viewProj, lightIndex_, map.firstView + face, size, footprint_, bias,
                                 compareTapRadius_},
                                {float(x), float(y), float(size), float(size), 0.0f, 1.0f},
                                {{x, y}, {size, size}}};
            const std::optional<VkRect2D> read = readWhole ? std::nullopt : casters_.readArea(draw.view);
            if (read) {
                // The read area in view texels, within the face.
                const int32_t x0 = std::clamp(read->offset.x, 0, int32_t(size));
                const int32_t y0 = std::clamp(read->offset.y, 0, int32_t(size));
                const int32_t x1 = std::clamp(read->offset.x + int32_t(read->extent.width), x0, int32_t(size));
                const int32_t y1 = std::clamp(read->offset.y + int32_t(read->extent.height), y0, int32_t(size));
                if (x0 == x1 || y0 == y1) continue;  // no receiver reads this face
                draw.scissor = {{x + x0, y + y0}, {uint32_t(x1 - x0), uint32_t(y1 - y0)}};
            }
            draws.faces.push_back(draw);
        }
    if (readWhole)
        draws.area = {{0, 0}, {target.desc().width, target.desc().height}};
    else if (draws.faces.empty())
        draws.area = {{0, 0}, {1, 1}};  // nothing read anywhere: one texel keeps the pass valid
    else
        draws.area = scissorUnion(draws.faces);
    return draws;
}

void ShadowMap::recordLayer(const graph::PassContext& pass, const std::string& image, ShadowDepthBias bias,
                            std::span<const ShadowMapPlacement> maps, const std::string* nearerLayer,
                            DrawFilter unmasked, MapClear clear) const
{
    VkCommandBuffer cmd = pass.cmd();
    const gpu::Image& target = pass.image(image);
    ShadowFaceDraws draws = faceDraws(pass, image, bias, maps);
    if (draws.faces.empty() && clear == MapClear::EachFace) return;  // nothing to draw, nothing to keep from harm
    VkRenderingAttachmentInfo depth{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
    depth.imageView = target.view();
    depth.imageLayout = pass.layout(image);
    depth.loadOp = clear == MapClear::Image ? VK_ATTACHMENT_LOAD_OP_CLEAR : VK_ATTACHMENT_LOAD_OP_LOAD;
    depth.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    depth.clearValue.depthStencil = {0.0f, 0};  // reversed-Z: far is 0
    if (clear == MapClear::EachFace) {
        // The texels outside the faces keep what they hold: the render area is the faces'
        // union, and each face's scissor is cleared on its own below.
        draws.area = scissorUnion(draws.faces);
    }
    VkRenderingInfo info{VK_STRUCTURE_TYPE_RENDERING_INFO};
    info.renderArea = draws.area;
    info.layerCount = 1;
    info.pDepthAttachment = &depth;
    vkCmdBeginRendering(cmd, &info);
    if (clear == MapClear::EachFace) {
        uint64_t texels = 0;
        std::vector<VkClearRect> rects;
        rects.reserve(draws.faces.size());
        for (const ShadowFaceDraw& face : draws.faces) {
            rects.push_back({face.scissor, 0, 1});
            texels += uint64_t(face.scissor.extent.width) * face.scissor.extent.height;
        }
        VkClearAttachment attachment{VK_IMAGE_ASPECT_DEPTH_BIT, 0, {}};
        attachment.clearValue.depthStencil = {0.0f, 0};
        vkCmdClearAttachments(cmd, 1, &attachment, uint32_t(rects.size()), rects.data());
        casters_.countRenderedTexels(texels);
    } else {
        casters_.countRenderedTexels(uint64_t(info.renderArea.extent.width) * info.renderArea.extent.height);
    }

    // Reversed-Z: "away from the light" is towards smaller depth, so every bias term is
    // negated; a negative clamp bounds the bias from below (Vulkan: max(bias, clamp)).
    vkCmdSetDepthBias(cmd, -bias.constant, -bias.clamp, -bias.slope);

    const bool masked = casters_.hasAlphaMasked();
    const gpu::Pipeline& solid = nearerLayer ? peel_ : depth_;
    const gpu::Pipeline& cutout = nearerLayer ? peelMasked_ : depthMasked_;
    // Every pipeline's descriptors: the casters' instances, and a peeled layer's nearer one.
    const auto descriptors = [&]() {
        gpu::DescriptorPush d;
        d.storageBuffer("Instances", casters_.instanceBuffer());
        if (nearerLayer)
            d.sampledImage("nearerLayer", pass.image(*nearerLayer), peelSampler_, pass.layout(*nearerLayer));
        return d;
    };
    bool solidBound = false;
    for (const ShadowFaceDraw& face : draws.faces) {
        const CasterView& view = face.view;
        vkCmdSetViewport(cmd, 0, 1, &face.viewport);
        vkCmdSetScissor(cmd, 0, 1, &face.scissor);
        // The solid pipeline stays bound across faces unless the masked one replaced it.
        if (!solidBound) {
            solid.bind(cmd);
            descriptors().push(context_, cmd, solid);
            solidBound = true;
        }
        solid.pushConstants(cmd, &view.viewProj, sizeof(glm::mat4));
        casters_.draw(cmd, view, unmasked);
        if (!masked) continue;
        cutout.bind(cmd);
        cutout.pushConstants(cmd, &view.viewProj, sizeof(glm::mat4));
        casters_.draw(cmd, view, DrawFilter::AlphaMasked, [&](const gpu::Image& texture) {
            descriptors()
                .storageBuffer("Materials", casters_.materialBuffer())
                .sampledImage("baseColorTexture", texture, casters_.textureSampler())
                .push(context_, cmd, cutout);
        });
        solidBound = false;
    }
    vkCmdEndRendering(cmd);
}

gpu::Sampler createShadowCompareSampler(gpu::Context& context, VkFilter filter)
{
    return gpu::createSampler(context, filter, VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE, VK_COMPARE_OP_GREATER_OR_EQUAL);
}

gpu::Sampler createShadowDepthSampler(gpu::Context& context)
{
    return gpu::createSampler(context, VK_FILTER_NEAREST, VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE);
}

float softShadowLightSize(const scene::Light& light, float overrideSize)
{
    // Directional lights: the angular diameter is clamped below 180° (tan(θ/2) is
    // finite); the techniques' texel radii clamp long before that.
    constexpr float kMaxAngularDiameterDeg = 179.0f;
    if (light.type == scene::LightType::Directional) {
        const float degrees = overrideSize >= 0.0f ? overrideSize : light.angularDiameterDeg;
        return 2.0f * std::tan(0.5f * glm::radians(std::clamp(degrees, 0.0f, kMaxAngularDiameterDeg)));
    }
    if (overrideSize >= 0.0f) return overrideSize;
    switch (light.type) {
    // The side of the square of equal area: one isotropic filter for an anisotropic
    // penumbra (it is w_x h / (H - h) along x, w_z h / (H - h) along z).
    case scene::LightType::Rect: return std::sqrt(std::max(light.sizeWorld.x * light.sizeWorld.y, 0.0f));
    case scene::LightType::Disk: return 2.0f * std::max(light.radiusWorld, 0.0f);
    default: return 0.0f;  // spot and point lights have no size of their own
    }
}

float softShadowKernelReach(const ShadowMapData& data, float lightSize)
{
    float reach = 0.0f;
    const float shape = lightShapeBound(data);
    const uint32_t faces = std::min(data.faceCount, kMaxShadowFaces);
    for (uint32_t f = 0; f < faces; ++f) {
        const ShadowFaceData& face = data.faces[f];
        const float texel = face.texel.x, near = face.depthRange.x, far = face.depthRange.y;
        const bool orthographic = face.depthRange.z != 0.0f;
        if (!(texel > 0.0f)) continue;  // a degenerate face: the techniques take one compare there
        // Written as the shaders divide, so that an inf or a NaN lands where theirs does:
        // a NaN (0 * inf, 0 / 0) counts 0, an inf stays and the limit clamps it.
        // The light's longest extent as any receiver sees it (lightShapeBound), at least
        // the square's: a light_size override is a square, and a reach too long only keeps
        // more casters.
        const float size = lightSize * shape;
        const float extent = orthographic ? std::max(far - near, 0.0f) * size : size / near;
        const float texels = 0.5f * extent / texel;
        if (texels > reach) reach = texels;
    }
    return reach;
}

float ShadowMap::setSoftShadowFootprint(float lightSize, float maxKernelTexels)
{
    footprint_ = std::min(softShadowKernelReach(data_, lightSize), maxKernelTexels) + 1.0f;
    return footprint_;
}

} // namespace penumbra::render
