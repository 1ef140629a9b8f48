#include "visibility/ReceiverFloorCulling.h"

#include "visibility/OcclusionTraversal.h"

#include <algorithm>
#include <bit>
#include <array>
#include <cmath>
#include <limits>
#include <optional>

namespace penumbra::visibility {
namespace {

// An instance whose box does not lie behind the floor is tested triangle by triangle when
// it has at most this many: a large flat receiver (a street, the ground) has a box that
// reaches towards the light far from where its surface lies, and is kept by the box test
// though its surface is behind every receiver depth it meets.
constexpr size_t kTriangleTestMaxTriangles = 256;
// Depth rounding between this plane fit (in double) and the rasterizer's interpolation
// (a few fp32 ulps of depths <= 1), as ReceiverMask.cpp's kFloorMargin: 16 ulps of 1.
constexpr double kPlaneMargin = 16.0 / 16777216.0;

// Whether a triangle with depth plane(x, y) (texel units), at most `nearest`, after its
// bias, lies behind the receiver depth at every texel centre of mask texel (mx, my)
// within its bounds `rect` (lo x, lo y, hi x, hi y).
bool texelsBehindReceivers(const ReceiverMask& mask, uint32_t mx, uint32_t my, const glm::dvec4& rect,
                           const glm::dvec3& plane, double nearest)
{
    const uint32_t x0 = std::max(mx * mask.block, uint32_t(std::max(rect.x, 0.0)));
    const uint32_t y0 = std::max(my * mask.block, uint32_t(std::max(rect.y, 0.0)));
    const uint32_t x1 = std::min({(mx + 1) * mask.block, mask.resolution, uint32_t(std::max(rect.z + 1.0, 0.0))});
    const uint32_t y1 = std::min({(my + 1) * mask.block, mask.resolution, uint32_t(std::max(rect.w + 1.0, 0.0))});
    for (uint32_t y = y0; y < y1; ++y) {
        for (uint32_t x = x0; x < x1; ++x) {
            const double depth =
                std::min(plane.x * (double(x) + 0.5) + plane.y * (double(y) + 0.5) + plane.z, nearest) + kPlaneMargin;
            // Non-negative floats order as their bits (receiver depths are stored clamped to
            // 0; below 0 lies beyond the far plane). Equal is kept.
            if (std::bit_cast<uint32_t>(float(std::max(depth, 0.0))) >= mask.receiverDepthBits(x, y)) return false;
        }
    }
    return true;
}

// Whether one triangle (clip-space corners) lies behind the receivers at every view texel
// it can cover, once the technique's bias has moved it away from the light, so that it
// can shadow no receiver there whatever else is drawn. Depth is an affine function of the
// texel position for perspective and orthographic views alike (z / w interpolates
// linearly on screen). Over a mask texel it is at most its largest value at the texel's
// four corners (and never more than the triangle's nearest corner): where that lies
// behind the floor, the whole block is; elsewhere each texel centre's depth is compared
// with that texel's receiver depth.
// The bias is taken at its least: the slope term alone, 0.99 of it (Vulkan's slope m is at
// least the larger texel derivative; the constant term only keeps more), at most the clamp.
bool triangleBehindFloor(const std::array<glm::dvec4, 3>& clip, const ReceiverMask& mask,
                         const render::ShadowDepthBias& bias)
{
    std::array<glm::dvec3, 3> p;  // texel x, texel y, depth
    const double res = double(mask.resolution);
    for (int k = 0; k < 3; ++k) {
        if (!(clip[k].w > 0.0) || clip[k].z > clip[k].w) return false;  // reaches the near plane
        p[k] = {(clip[k].x / clip[k].w * 0.5 + 0.5) * res, (clip[k].y / clip[k].w * 0.5 + 0.5) * res,
                clip[k].z / clip[k].w};
    }
    const double nearest = std::max({p[0].z, p[1].z, p[2].z});
    const double lo[2] = {std::min({p[0].x, p[1].x, p[2].x}) - 1.0, std::min({p[0].y, p[1].y, p[2].y}) - 1.0};
    const double hi[2] = {std::max({p[0].x, p[1].x, p[2].x}) + 1.0, std::max({p[0].y, p[1].y, p[2].y}) + 1.0};
    const double block = double(mask.block), last = double(mask.size - 1);
    const double x0 = std::max(std::floor(lo[0] / block), 0.0), y0 = std::max(std::floor(lo[1] / block), 0.0);
    const double x1 = std::min(std::floor(hi[0] / block), last), y1 = std::min(std::floor(hi[1] / block), last);
    if (x1 < x0 || y1 < y0) return true;  // off the view
    // depth = a x + b y + c through the three corners; an edge-on triangle (no plane) takes
    // its nearest corner's depth everywhere.
    const glm::dvec3 e1 = p[1] - p[0], e2 = p[2] - p[0];
    const double det = e1.x * e2.y - e1.y * e2.x;
    const double extent = std::max(hi[0] - lo[0], hi[1] - lo[1]);
    const bool planar = std::abs(det) > 1e-6 * extent * extent;
    const double a = planar ? (e1.z * e2.y - e2.z * e1.y) / det : 0.0;
    const double b = planar ? (e2.z * e1.x - e1.z * e2.x) / det : 0.0;
    const double c = planar ? p[0].z - a * p[0].x - b * p[0].y : nearest;
    double slopeBias = planar ? 0.99 * double(bias.slope) * std::max(std::abs(a), std::abs(b)) : 0.0;
    if (bias.clamp > 0.0f) slopeBias = std::min(slopeBias, double(bias.clamp));
    const std::vector<float>& floor = mask.floorLevels.front();
    for (auto y = uint32_t(y0); y <= uint32_t(y1); ++y) {
        for (auto x = uint32_t(x0); x <= uint32_t(x1); ++x) {
            const float cell = floor[size_t(y) * mask.size + x];
            if (std::isinf(cell)) continue;
            // The plane's largest value over the texel: at the corner its gradient points to.
            const double cx = (a > 0.0 ? double(x + 1) : double(x)) * block;
            const double cy = (b > 0.0 ? double(y + 1) : double(y)) * block;
            const double depth = std::min(a * cx + b * cy + c, nearest) - slopeBias;
            if (depth + kPlaneMargin < double(cell)) continue;
            if (!texelsBehindReceivers(mask, x, y, {lo[0], lo[1], hi[0], hi[1]}, {a, b, c}, nearest - slopeBias))
                return false;
        }
    }
    return true;
}

// Whether every triangle of an instance lies behind the receiver floor.
bool trianglesBehindFloor(const scene::Scene& scene, uint32_t instance, const glm::mat4& viewProj,
                          const ReceiverMask& mask, const render::ShadowDepthBias& bias)
{
    const scene::Instance& inst = scene.instances[instance];
    const scene::Mesh& mesh = scene.meshes[inst.mesh];
    if (mesh.indices.size() / 3 > kTriangleTestMaxTriangles) return false;
    const glm::dmat4 toClip = glm::dmat4(viewProj) * glm::dmat4(scene.instanceTransform(inst));
    for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
        std::array<glm::dvec4, 3> clip;
        for (int k = 0; k < 3; ++k) clip[k] = toClip * glm::dvec4(glm::dvec3(mesh.vertices[mesh.indices[t + k]].position), 1.0);
        if (!triangleBehindFloor(clip, mask, bias)) return false;
    }
    return true;
}

// Whether nothing inside `box` could change what a receiver gets from the view's map: it
// lies outside the view, projects onto no mask texel, or lies behind the receiver floor
// wherever it projects. A box that reaches the near plane has no projection and is kept.
bool culled(const scene::Aabb& box, const scene::Frustum& frustum, const glm::mat4& viewProj,
            const ReceiverMask& mask, CullingStats& stats)
{
    if (box.empty() || outside(frustum, box)) return true;
    const std::optional<ProjectedBox> projected = projectBox(viewProj, box, mask.resolution, mask.resolution);
    if (!projected) return false;
    if (mask.rejects(projected->rect)) {
        ++stats.maskRejected;
        return true;
    }
    if (mask.behindReceivers(projected->rect, projected->nearestDepth)) {
        ++stats.floorRejected;
        return true;
    }
    return false;
}

} // namespace

void cullBehindReceivers(const scene::InstanceBvh& bvh, const scene::Scene& scene, const glm::mat4& viewProj,
                         const render::ShadowDepthBias& bias, const ReceiverMask& mask, std::vector<uint8_t>& visible,
                         CullingStats& stats)
{
    visible.assign(scene.instances.size(), 0);
    if (bvh.nodeCount() == 0) return;
    const scene::Frustum frustum = scene::frustumFromViewProj(viewProj);
    std::vector<uint32_t> stack{0};
    while (!stack.empty()) {
        const uint32_t node = stack.back();
        stack.pop_back();
        ++stats.nodesVisited;
        if (culled(bvh.nodeBounds(node), frustum, viewProj, mask, stats)) continue;
        if (!bvh.isLeafNode(node)) {
            stack.push_back(bvh.firstChild(node));
            stack.push_back(bvh.firstChild(node) + 1);
            continue;
        }
        // A leaf's instances one by one: its box holds them all, theirs are tighter.
        for (const uint32_t i : bvh.leafInstances(node)) {
            if (culled(scene.instances[i].worldBounds, frustum, viewProj, mask, stats)) continue;
            if (trianglesBehindFloor(scene, i, viewProj, mask, bias)) {
                ++stats.floorRejected;
                continue;
            }
            visible[i] = 1;
        }
    }
}

} // namespace penumbra::visibility
