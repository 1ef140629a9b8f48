#pragma once
// A technique's V_l given as a GLSL function of one G-buffer sample (docs/plugins.md,
// "Visibility as a function"). Where something besides shading reads the light's
// visibility image (a comparison, --visibility-exr, a debug image, the viewer's
// inspector) the engine runs it as the technique's visibility pass, which writes the
// image as addVisibilityPass's would; where nothing does, shading evaluates it for every
// pixel and the image is never allocated or written. Shading then sees the very value
// the image would have held (rounded to VISIBILITY_FORMAT), so the pixels are the same
// either way.
//
// The function's file, in the plugin's shader folder, is GLSL without #version:
//
//     layout(binding = VISIBILITY_BINDING(0)) uniform sampler2DShadow shadowMap;
//     float techniqueVisibility(ivec2 pixel, vec3 position, vec3 normal) { ... }
//
// It is included after common/gbuffer.glsl and common/visibility.glsl (gbufferPosition,
// gbufferNormal of neighbouring pixels are there), declares its resources at
// VISIBILITY_BINDING(k), k < kMaxVisibilityFunctionBindings (an array of descriptors is one
// binding), and takes its parameters as
// defines (floatDefine): no push constants, no main(). It is called for every pixel with
// geometry (position: gbufferPosition(pixel).xyz, normal: gbufferNormal(pixel)) and
// returns V in [0, 1]; names it declares are its own (the engine prefixes them per
// light: gpu/GlslNames.h).
#include "penumbra/gpu/Pipeline.h"
#include "penumbra/gpu/ShaderCompiler.h"
#include "penumbra/graph/RenderGraph.h"
#include "penumbra/plugin/Technique.h"
#include "penumbra/plugin/VisibilityPass.h"

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace penumbra::plugin {

inline constexpr uint32_t kMaxVisibilityFunctionBindings = 4;

// A GLSL literal that reads back as `value` (finite: throws penumbra::Error otherwise),
// and a float parameter as a define of it.
std::string floatLiteral(float value);
gpu::ShaderDefine floatDefine(std::string name, float value);

class VisibilityFunction {
public:
    VisibilityFunction() = default;
    // Compiles the visibility pass around `shader` (relative to the plugin's shader folder)
    // with `defines`: a shader error or a binding past kMaxVisibilityFunctionBindings
    // throws here, when the technique is created. The pass runs local size
    // `localSizeX` x `localSizeY`.
    VisibilityFunction(const TechniqueSetup& setup, const std::filesystem::path& shader,
                       std::vector<gpu::ShaderDefine> defines, uint32_t localSizeX = 64, uint32_t localSizeY = 1);

    const gpu::ShaderCompiler& compiler() const { return *compiler_; }
    const std::filesystem::path& shader() const { return shader_; }  // resolved
    const std::vector<gpu::ShaderDefine>& defines() const { return defines_; }
    const gpu::Pipeline& passPipeline() const { return pass_; }
    // The descriptors its bindings hold (an array counts each element): what shading's
    // push descriptors must make room for.
    uint32_t descriptorCount() const { return descriptorCount_; }
    // The function as shading holds it: preprocessed after the head both share, its
    // bindings from `bindingBase` on (the engine prefixes its names: gpu/GlslNames.h).
    std::string preprocessedUnit(uint32_t bindingBase) const;

private:
    const gpu::ShaderCompiler* compiler_ = nullptr;
    std::filesystem::path shader_;
    std::vector<gpu::ShaderDefine> defines_;
    gpu::Pipeline pass_;
    uint32_t descriptorCount_ = 0;
};

// The head every visibility function is compiled after: #version, `extensions` (whole
// "#extension" lines), common/gbuffer.glsl at bindings 0..2 and common/visibility.glsl.
// The visibility pass and shading (which composes its functions after it) share it.
std::string visibilityFunctionHead(const std::string& extensions = {});

// The visibility pass's source around the function file `function` (a resolved path):
// what VisibilityFunction compiles, with its defines, as a compute shader named beside it.
// Shader tests compile a function's variants with it.
std::string visibilityPassSource(const std::filesystem::path& function);

// What a light hands the engine's shading when shading evaluates its visibility.
struct VisibilityInShading {
    const VisibilityFunction* function = nullptr;
    std::vector<std::string> sampledReads;  // graph resources its lookups sample
    BindVisibilityFn bind;                  // its descriptors, by its own names; no push constants
};

// Gives V_l as `function`, whose lookups sample `sampledReads` and whose descriptors
// `bind` adds (it must push no constants). Declares the pass io.local("visibility") that
// writes io.visibility, as addVisibilityPass does, unless the engine takes the function
// into shading (io.evaluateInShading); the pass depends on io.lightState and
// io.cameraState. `function` must live as long as the technique.
void addVisibilityFunction(graph::RenderGraph& graph, const LightPassIo& io, const VisibilityFunction& function,
                           std::vector<std::string> sampledReads, BindVisibilityFn bind);

} // namespace penumbra::plugin
