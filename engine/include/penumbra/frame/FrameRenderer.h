#pragma once
// One frame, end to end (DESIGN.md), as a render graph: the engine's G-buffer pass ->
// per light, the passes its technique plugin registers, which write the light's
// visibility image V_l -> the engine's shading pass (reads every V_l) -> colour image.
// The engine itself contains no shadow technique: a light whose plugin could not be
// loaded or registered (and is not required) is lit unshadowed, with a warning; a light
// whose technique is "none" (config::kNoShadowTechnique) has no V_l at all and shading
// takes V = 1 for it. Before any pass is declared, each frame decides which lights can
// matter (LightInfluence.h): a culled light has no passes and adds no light, a light
// beyond max_shadowed_lights is lit unshadowed.
#include "penumbra/config/Config.h"
#include "penumbra/frame/BaseColorPipelines.h"
#include "penumbra/gpu/Context.h"
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/gpu/Resources.h"
#include "penumbra/gpu/ShaderCompiler.h"
#include "penumbra/graph/GraphExecutor.h"
#include "penumbra/graph/RenderGraph.h"
#include "penumbra/metrics/DebugImage.h"
#include "penumbra/plugin/GBuffer.h"
#include "penumbra/plugin/PluginRegistry.h"
#include "penumbra/plugin/VisibilityFunction.h"
#include "penumbra/render/Casters.h"
#include "penumbra/frame/FrameChanges.h"
#include "penumbra/frame/LightInfluence.h"
#include "penumbra/frame/SceneResources.h"
#include "penumbra/render/Projection.h"
#include "penumbra/render/SceneGpu.h"
#include "penumbra/visibility/CullingStats.h"

#include <map>
#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace penumbra::visibility {
class Visibility;  // private to the engine (engine/src/visibility/)
}

namespace penumbra::frame {

using PassTiming = graph::PassTiming;

// The most times renderFrame() draws a frame again for techniques that grew their
// resources or refined what they store for this view (plugin::Technique::wantsRedraw):
// a deep shadow map's pool grows in one redraw, an adaptive shadow map settles a still
// view in one redraw per quadtree level it adds.
inline constexpr uint32_t kMaxRedraws = 16;

struct FrameTimings {
    std::vector<PassTiming> passes;    // the executed passes (of the last draw), in execution order
    double frameCpuMs = 0.0;           // record + submit + wait (+ host passes), wall clock, every draw
    visibility::CullingStats culling;  // the visibility service's figures for the frame
    // Per light (empty for a light without technique): its technique's figures.
    std::vector<std::vector<plugin::TechniqueFigure>> techniques;
    uint32_t redraws = 0;  // draws after the first (a technique grew its resources)
    std::vector<LightDecision> lights;  // per light: shadowed, unshadowed or culled this frame, and why
};

class FrameRenderer {
public:
    // Loads the technique plugin of every light from `plugins` (which must outlive the
    // renderer), creates one technique per light and builds the frame's graph over
    // `resources` (made with the config's draw batching, else Error). The scene must
    // outlive the renderer: techniques keep it (TechniqueSetup::scene). Throws
    // plugin::PluginError when a required technique fails, penumbra::Error (naming the
    // pass) when the graph does not compile.
    //
    // An edit of a config drawn by `previous` (over the same resources, plugins and
    // output): a light whose technique, parameters and light shape (type, cones, sizes)
    // are unchanged at the same index takes previous's technique instance, with the state
    // it grew (an adaptive shadow map's quadtree, a deep shadow map's pool); only the
    // other lights' techniques are created. `previous` stays usable: it declares its graph
    // again before its next frame when a shared technique was declared by another.
    FrameRenderer(std::shared_ptr<SceneResources> resources, const config::RenderConfig& config,
                  plugin::PluginRegistry& plugins, const FrameRenderer* previous = nullptr);
    // The same over resources of its own (one config drawn once: tests, tools).
    FrameRenderer(gpu::Context& context, const scene::Scene& scene, const config::RenderConfig& config,
                  plugin::PluginRegistry& plugins);
    ~FrameRenderer();
    FrameRenderer(const FrameRenderer&) = delete;
    FrameRenderer& operator=(const FrameRenderer&) = delete;

    // Takes the camera, the lights and moved scene nodes of an animated frame: call it
    // after config::applyAnimation and scene.updateTransforms(), before renderFrame().
    // `scene` is the one the renderer was built with (animated in place; another throws);
    // `movedInstances` is what updateTransforms() returned.
    void update(const config::RenderConfig& config, const scene::Scene& scene,
                const std::vector<uint32_t>& movedInstances);

    // Runs one frame (GraphExecutor::execute: one submission, or one per stretch of GPU
    // passes between host passes) and waits for it; returns the time of every pass. When
    // a technique grew a resource the frame did not fit in (Technique::wantsRedraw),
    // the graph is declared again and the frame drawn again, up to kMaxRedraws times.
    FrameTimings renderFrame();

    uint32_t width() const { return width_; }
    uint32_t height() const { return height_; }
    size_t lightCount() const { return lights_.size(); }
    const glm::mat4& cameraViewProj() const { return cameraViewProj_; }

    // Lights rendered without their technique (plugin failed, not required): one line
    // each, naming light, plugin and the error.
    const std::vector<std::string>& warnings() const { return warnings_; }
    // The technique a light uses ("hard", or "none" for an unshadowed light), empty when it
    // fell back to unshadowed.
    const std::string& techniqueName(size_t light) const { return lights_.at(light).technique; }
    // What the names of a light's shadow passes and resources begin with: its technique's
    // LightPassIo::prefix ("light0.hard."), or "light0.unshadowed" for a light that fell
    // back to unshadowed, which names no pass (it has none). For timing and memory per
    // technique.
    std::string shadowPassPrefix(size_t light) const;

    // The frame's graph as compiled (passes in order, culled passes and why, resources
    // with sizes and aliasing), and the executor that allocated its memory.
    const graph::CompiledGraph& compiledGraph();
    const graph::GraphExecutor& executor() const { return executor_; }
    const SceneResources& resources() const { return *resources_; }
    std::shared_ptr<SceneResources> sharedResources() const { return resources_; }
    // Light `light`'s fate this frame (shadowed, unshadowed or culled, and why), as the
    // last constructor or update() decided it.
    const LightDecision& lightDecision(size_t light) const { return lights_.at(light).decision; }

    // Whether light `light`'s technique instance was taken from the previous renderer.
    bool techniqueKept(size_t light) const { return lights_.at(light).kept; }

    // Debug images: any image a pass of the frame writes (imageNames(): the G-buffer,
    // every technique's maps and tables, the visibility images, the colour image), by
    // name. A requested image is kept, with the passes that write it, even where nothing
    // else reads it (graph culling would drop them), and readImage() reads it after
    // renderFrame(); unrequested, it costs nothing. Throws ConfigError naming an unknown
    // name and listing the frame's images.
    std::vector<std::string> imageNames() const;
    void requestImage(const std::string& name);
    metrics::DebugImageValues readImage(const std::string& name) const;

    // Whether the lights' visibility images V_l are there to be read back (readVisibility,
    // readPixel, debug images): true unless set otherwise. False lets shading evaluate
    // the visibility of every light whose technique gives it as a function
    // (plugin/VisibilityFunction.h) as far as shading's descriptors allow; such a light
    // has no image, and readVisibility / readPixel throw for it. Declares the frame's
    // graph again when it changes.
    void setVisibilityReadBack(bool readBack);
    // Whether shading adds each light only over its rectangle of the screen
    // (frame/LightInfluence.h lightScreenRect): true unless set otherwise. The same image
    // either way (a spot light adds exactly 0 outside its cone, the others less than a
    // display step beyond their range); false for comparisons.
    void setLightRegions(bool regions);
    // Shading's dispatches, decided with the lights (constructor, update()): rectangles
    // covering the screen once, each with the lights (a bit per light) shading adds there.
    struct ShadingRegion {
        ScreenRect rect;
        uint32_t shaded = 0;
    };
    const std::vector<ShadingRegion>& shadingRegions() const { return shadingRegions_; }
    // Whether shading evaluates light `light`'s visibility this frame (it has no image).
    bool visibilityInShading(size_t light) const { return lights_.at(light).inShading.has_value(); }

    // Read-back after renderFrame(): sRGB RGBA8 rows, top row first.
    std::vector<uint8_t> readColor() const;
    // V_l, one float per pixel (all 1 for a light without an image this frame: technique
    // "none", unshadowed by max_shadowed_lights, or culled).
    std::vector<float> readVisibility(size_t light) const;
    // One pixel of both (a pixel inspector's read: two texels copied, not two images):
    // readColor()'s RGBA8 and every light's V at (x, y) < (width(), height()).
    struct Pixel {
        std::array<uint8_t, 4> color{};
        std::vector<float> visibility;  // per light
    };
    Pixel readPixel(uint32_t x, uint32_t y) const;
    // G-buffer world positions as the techniques read them (rebuilt from the depth,
    // plugin::GBufferExport), four floats per pixel (all 0 where no geometry, w = 1
    // elsewhere).
    std::vector<float> readPositions() const;
    // G-buffer unit world normals, four floats per pixel (w: the position's error bound,
    // gbufferPositionError; all 0 where no geometry).
    std::vector<float> readNormals() const;

private:
    // A technique instance with what its TechniqueSetup refers to; shared by the renderers
    // of successive edits that keep it.
    struct CreatedTechnique {
        const plugin::LoadedPlugin* plugin = nullptr;
        std::string name;
        nlohmann::json params;  // resolved values (defaults filled in): what an edit compares
        std::unique_ptr<plugin::ParamValues> values;
        scene::Light light;  // the state the technique was created with (its setup refers to it)
        // The renderer whose graph holds its passes now: another must declare its graph
        // again before it draws.
        const FrameRenderer* declaredBy = nullptr;
        std::unique_ptr<plugin::Technique> instance;  // last: destroyed first
    };
    struct LightSlot {
        std::string technique;  // empty: unshadowed fallback
        std::shared_ptr<CreatedTechnique> created;
        plugin::Technique* instance = nullptr;  // created->instance, or none
        bool kept = false;      // created by a previous renderer
        bool required = false;
        bool unshadowed = false;  // technique "none": no passes, no visibility image
        std::string visibility;  // "light<i>.visibility"
        LightDecision decision;  // this frame's
        // Its technique's visibility function, where shading evaluates it (no image).
        std::optional<plugin::VisibilityInShading> inShading;
        // Whether its technique draws this frame: it then gives the light's V_l.
        bool drawn() const { return !unshadowed && instance && decision.fate == LightFate::Shadowed; }
        // Whether it gives V_l as an image that shading reads.
        bool hasImage() const { return drawn() && !inShading; }
    };

    struct SurfaceFloats {
        std::vector<float> positions, normals;
    };

    void createTechniques(const config::RenderConfig& config, const FrameRenderer* previous);
    std::shared_ptr<CreatedTechnique> keptTechnique(const FrameRenderer* previous, size_t light,
                                                    const config::LightConfig& config,
                                                    const plugin::LoadedPlugin& plugin, const nlohmann::json& params) const;
    const gpu::Pipeline& shadingPipeline(uint32_t shaded);
    // lightRects_ and shadingRegions_ from the lights' screen rectangles.
    void decideRegions();
    // V = 1 over a light's visibility image outside `inside` (LightPassIo::fillOutside).
    void fillVisibility(VkCommandBuffer cmd, const gpu::Image& image, VkRect2D inside);
    const gpu::Pipeline& visibilityFillPipeline();
    bool shadingTakesFunction(const plugin::VisibilityFunction& function) const;
    // The first binding of light `light`'s visibility function in shading (engine/shading.glsl
    // uses 0..6).
    static constexpr uint32_t kFunctionBindingBase = 8;
    static uint32_t functionBindingBase(size_t light);
    std::string noVisibilityImage(size_t light) const;
    void setCamera(const scene::Camera& camera);
    plugin::GBufferIo gbufferIo() const;
    SurfaceFloats readSurfaces() const;
    void buildGraph();
    bool registerTechnique(size_t light);
    void dropTechnique(size_t light, const std::string& why);
    void updateLights(const config::RenderConfig& config, const scene::Aabb& sceneBounds);
    void decideLights();
    std::vector<LightFate> fates() const;
    void noteChanges(std::span<const uint32_t> movedInstances);
    void execute();
    void recordGBuffer(graph::PassContext& pass);
    void recordShading(graph::PassContext& pass);
    std::vector<float> readFloats(const std::string& name) const;

    std::shared_ptr<SceneResources> resources_;
    gpu::Context& context_;
    plugin::PluginRegistry& plugins_;
    const scene::Scene& scene_;
    uint32_t width_ = 0;
    uint32_t height_ = 0;
    glm::mat4 cameraViewProj_{1.0f};
    glm::vec3 cameraPosition_{0.0f};
    bool lightCulling_ = true;
    uint32_t maxShadowedLights_ = config::kMaxLights;
    glm::vec4 ambient_{0.0f};
    glm::vec4 background_{0.0f};

    std::shared_ptr<visibility::Visibility> visibility_;
    gpu::Buffer lightBuffer_;
    gpu::Buffer gbufferCamera_;  // GBufferCamera (common/gbuffer.glsl), rewritten by setCamera
    // resources_'s, for this layout of lights, by the lights they add
    std::map<uint32_t, const gpu::Pipeline*> shadingPipelines_;
    std::vector<ShadingRegion> shadingRegions_;  // decideLights's
    std::vector<ScreenRect> lightRects_;          // each light's, the same decision's (empty: culled)
    std::vector<scene::Aabb> receiversInView_;   // the instances' boxes decideLights saw
    bool lightRegions_ = true;
    std::vector<LightSlot> lights_;
    std::vector<scene::Light> currentLights_;  // as the last update() left them
    std::vector<std::string> warnings_;
    std::vector<std::string> requestedImages_;  // marked outputs again when the graph is declared again
    bool castersFollowCamera_ = false;  // culling or focusing: the casters drawn depend on the camera
    FrameChanges changes_;
    bool keepUnchanged_ = true;  // "keep_unchanged"
    bool visibilityReadBack_ = true;
    std::unique_ptr<graph::RenderGraph> graph_;
    graph::GraphExecutor executor_;
};

} // namespace penumbra::frame
